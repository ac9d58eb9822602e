//! "Did you mean ...?" suggestions for misspelt names.

/// Levenshtein distance between two strings (by `char`), case-insensitive.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.to_lowercase().chars().collect();
    let b: Vec<char> = b.to_lowercase().chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for i in 1..=a.len() {
        cur[0] = i;
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            cur[j] = (prev[j] + 1).min(cur[j - 1] + 1).min(prev[j - 1] + cost);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The candidate nearest to `name`, if it is close enough to be a plausible
/// misspelling (distance at most a third of the longer name, at least 2).
pub fn nearest<'a, I: IntoIterator<Item = &'a str>>(name: &str, candidates: I) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (edit_distance(name, c), c))
        .min_by_key(|(d, _)| *d)
        .filter(|(d, c)| *d <= (name.len().max(c.len()) / 3).max(2))
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("CartPole-v0", "cartpole-v0"), 0);
    }

    #[test]
    fn suggests_close_names_only() {
        let ids = ["CartPole-v0", "CartPole-v1", "Acrobot-v1"];
        assert_eq!(nearest("CartPol-v1", ids), Some("CartPole-v1"));
        assert_eq!(nearest("Acrobot", ids), Some("Acrobot-v1"));
        assert_eq!(nearest("Humanoid-v4", ids), None);
    }
}
