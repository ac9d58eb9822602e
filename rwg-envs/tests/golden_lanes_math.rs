//! `rwg_env::lanes_math` on the golden trajectories' angles: every recorded
//! state value of every golden file (`tests/data/*.json`, from Gymnasium and
//! glibc 2.36), and the arguments the envs derive from them (Acrobot's
//! theta1 + theta2 and the -pi/2 shifts, Pendulum's th + pi, the mountain
//! cars' 3 pos), through `sin_lanes`/`cos_lanes`/`sincos_lanes` in 16-lane
//! slices, must give libm's `sin` and `cos` bits (one call each).

use rwg_env::lanes_math::{cos_lanes, sin_lanes, sincos_lanes};
use std::f64::consts::{FRAC_PI_2, PI};
use std::hint::black_box;
use std::path::PathBuf;

/// Every number in `v` (the states are arrays of numbers).
fn numbers(v: &serde_json::Value, out: &mut Vec<f64>) {
    match v {
        serde_json::Value::Number(n) => out.extend(n.as_f64()),
        serde_json::Value::Array(a) => a.iter().for_each(|x| numbers(x, out)),
        _ => {}
    }
}

/// The sin/cos arguments of env `id` derived from the state values `s`.
fn arguments(id: &str, states: &[Vec<f64>]) -> Vec<f64> {
    let mut x = Vec::new();
    for s in states {
        x.extend_from_slice(s);
        match id {
            "Acrobot-v1" if s.len() >= 2 => {
                x.extend([s[0] + s[1], s[0] - FRAC_PI_2, s[0] + s[1] - FRAC_PI_2])
            }
            id if id.starts_with("Pendulum") => x.push(s[0] + PI),
            id if id.starts_with("MountainCar") => x.push(3.0 * s[0]),
            _ => {}
        }
    }
    x
}

#[test]
fn golden_angles_give_libm_bits() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data");
    // Called through black_box'd pointers so LLVM cannot merge them into sincos.
    let libm_sin: fn(f64) -> f64 = black_box(f64::sin);
    let libm_cos: fn(f64) -> f64 = black_box(f64::cos);
    let mut checked = 0;
    for id in [
        "Acrobot-v1",
        "CartPole-v0",
        "CartPole-v1",
        "MountainCar-v0",
        "MountainCarContinuous-v0",
        "Pendulum-v0",
        "Pendulum-v1",
    ] {
        let path = dir.join(format!("{id}.json"));
        let text = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let mut states = Vec::new();
        for t in v["trajectories"].as_array().unwrap() {
            let mut s = Vec::new();
            numbers(&t["reset_state"], &mut s);
            states.push(s);
            for step in t["steps"].as_array().unwrap() {
                let mut s = Vec::new();
                numbers(&step["state"], &mut s);
                states.push(s);
            }
        }
        let x = arguments(id, &states);
        assert!(x.len() > 100, "{id}: only {} arguments", x.len());
        let (mut s, mut c, mut s2, mut c2) = (
            vec![0.0; x.len()],
            vec![0.0; x.len()],
            vec![0.0; x.len()],
            vec![0.0; x.len()],
        );
        for i in (0..x.len()).step_by(16) {
            let e = (i + 16).min(x.len());
            sin_lanes(&x[i..e], &mut s[i..e]);
            cos_lanes(&x[i..e], &mut c[i..e]);
            sincos_lanes(&x[i..e], &mut s2[i..e], &mut c2[i..e]);
        }
        for (i, &a) in x.iter().enumerate() {
            let (ws, wc) = (libm_sin(a).to_bits(), libm_cos(a).to_bits());
            assert_eq!(s[i].to_bits(), ws, "{id}: sin({a:e})");
            assert_eq!(c[i].to_bits(), wc, "{id}: cos({a:e})");
            assert_eq!(s2[i].to_bits(), ws, "{id}: sincos({a:e}).0");
            assert_eq!(c2[i].to_bits(), wc, "{id}: sincos({a:e}).1");
        }
        checked += x.len();
    }
    eprintln!(
        "{checked} golden arguments, lanes_math: {}",
        rwg_env::lanes_math::implementation()
    );
}
