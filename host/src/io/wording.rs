//! Counts with their noun in what the tools print (`1 shock`, `3 shocks`), for commands
//! and the demo alike.

/// `n` and the noun, plural unless `n` is 1: `1 shock`, `3 shocks`, `0 shocks`.
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

#[cfg(test)]
mod tests {
    use super::count;

    #[test]
    fn counts_are_singular_for_one_only() {
        assert_eq!(count(0, "shock"), "0 shocks");
        assert_eq!(count(1, "shock"), "1 shock");
        assert_eq!(count(2, "level change"), "2 level changes");
    }
}
