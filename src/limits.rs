//! Upper bounds on the sizes a caller may ask for, so that a request that cannot be
//! allocated is an error naming the value and the bound instead of an aborted process.

use crate::error::{check_size, Result};

/// Most links a chain may have (the O(n) dynamics would handle more, but the
/// analysis is O(n^3) and per-link buffers are allocated eagerly).
pub const MAX_LINKS: usize = 100_000;

/// Most float64 numbers in one state array of a batch (`num_envs * state_dim`) or in
/// one simulated trajectory (`(steps + 1) * state_dim`): 2^27, one GiB.
pub const MAX_STATE_VALUES: usize = 1 << 27;

/// `n_links` within [`MAX_LINKS`].
pub fn check_links(n_links: usize) -> Result<()> {
    check_size("n_links", n_links, MAX_LINKS)
}

/// `count` rows of `state_dim` numbers within [`MAX_STATE_VALUES`], naming `name`.
pub fn check_rows(name: &'static str, count: usize, state_dim: usize) -> Result<()> {
    check_size(name, count, MAX_STATE_VALUES / state_dim.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::{ChainError, InputError};
    use crate::ChainParams;

    #[test]
    fn sizes_beyond_the_limits_are_refused_before_allocating() {
        let e = ChainParams::uniform(MAX_LINKS + 1, 1.0, 0.1, 0.1, 9.81).unwrap_err();
        assert_eq!(
            e,
            ChainError::Input(InputError::TooLarge {
                name: "n_links",
                value: MAX_LINKS + 1,
                limit: MAX_LINKS
            })
        );
        assert!(check_rows("num_envs", MAX_STATE_VALUES / 8, 8).is_ok());
        assert!(check_rows("num_envs", MAX_STATE_VALUES / 8 + 1, 8).is_err());
        assert!(check_rows("num_envs", usize::MAX, 8).is_err());
    }
}
