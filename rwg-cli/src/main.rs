//! The `rwg` command-line tool.

fn main() {
    println!("rwg");
}
