//! Goal-conditioned tasks: the (start, target) pairs of equilibria that episodes are
//! drawn from. Each reset of such a task draws one pair uniformly from its env's start
//! stream, starts near the pair's start equilibrium and scores against its target.

use crate::analysis::check_signs;
use crate::error::{InputError, Result};

/// Most links a task may draw its equilibria from (`2^n (2^n - 1)` pairs, indexed by a
/// 16-bit number per env).
pub const MAX_DRAWN_LINKS: usize = 8;

/// Start and target equilibria of the transitions episodes are drawn from, `n` signs
/// each, pair by pair.
#[derive(Debug, Clone, PartialEq)]
pub struct Transitions {
    n: usize,
    starts: Vec<f64>,
    targets: Vec<f64>,
}

/// Which equilibria a draw may pick for one end of a transition: one given, or any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ends<'a> {
    /// This equilibrium.
    One(&'a [f64]),
    /// Any of the `2^n`.
    Any,
}

impl Transitions {
    /// The pairs given, each checked (`n` signs +1/-1 at both ends).
    pub fn from_pairs(n: usize, pairs: &[(Vec<f64>, Vec<f64>)]) -> Result<Self> {
        if pairs.is_empty() || pairs.len() > u16::MAX as usize {
            return Err(InputError::InvalidParameter {
                name: "transitions",
                value: pairs.len() as f64,
                expected: "between 1 and 65535 (start, target) pairs",
            }
            .into());
        }
        let (mut starts, mut targets) = (Vec::new(), Vec::new());
        for (start, target) in pairs {
            check_signs(start, n)?;
            check_signs(target, n)?;
            starts.extend_from_slice(start);
            targets.extend_from_slice(target);
        }
        Ok(Self { n, starts, targets })
    }

    /// Every pair of distinct equilibria with `start` at one end and `target` at the
    /// other (`Any`: each of the `2^n`); with a start given as the target itself
    /// (`start_at_target`), every target with its own start.
    pub fn between(
        n: usize,
        start: Ends<'_>,
        target: Ends<'_>,
        start_at_target: bool,
    ) -> Result<Self> {
        if n > MAX_DRAWN_LINKS {
            return Err(InputError::InvalidParameter {
                name: "n_links",
                value: n as f64,
                expected:
                    "at most 8 for a task that draws its equilibria (start or target \"any\")",
            }
            .into());
        }
        let all: Vec<Vec<f64>> = (0..1usize << n).map(|bits| signs_of(bits, n)).collect();
        let ends = |e: Ends<'_>| match e {
            Ends::One(s) => vec![s.to_vec()],
            Ends::Any => all.clone(),
        };
        let mut pairs = Vec::new();
        for t in ends(target) {
            if start_at_target {
                pairs.push((t.clone(), t));
                continue;
            }
            for s in ends(start) {
                if s != t {
                    pairs.push((s, t.clone()));
                }
            }
        }
        if pairs.is_empty() {
            return Err(InputError::Incompatible {
                name: "start",
                value: "the target's equilibrium",
                expected: "an equilibrium other than the target (the only one left)".to_string(),
            }
            .into());
        }
        // Start-major order: all targets of the first start first.
        pairs.sort_by_key(|(s, t)| key(s, t));
        Self::from_pairs(n, &pairs)
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.starts.len() / self.n.max(1)
    }

    /// Never true: a task has at least one pair.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Start signs of pair `k`.
    pub fn start(&self, k: usize) -> &[f64] {
        &self.starts[k * self.n..(k + 1) * self.n]
    }

    /// Target signs of pair `k`.
    pub fn target(&self, k: usize) -> &[f64] {
        &self.targets[k * self.n..(k + 1) * self.n]
    }
}

/// The signs of equilibrium number `bits` in binary order (bit i set: link i upright),
/// hanging first, as `ChainCart.equilibria` lists them.
fn signs_of(bits: usize, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            if bits >> (n - 1 - i) & 1 == 1 {
                -1.0
            } else {
                1.0
            }
        })
        .collect()
}

/// Sort key of a pair: binary numbers of its start and target.
fn key(start: &[f64], target: &[f64]) -> (usize, usize) {
    let number = |s: &[f64]| s.iter().fold(0, |acc, &v| 2 * acc + (v < 0.0) as usize);
    (number(start), number(target))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn any_to_any_is_every_ordered_pair_of_distinct_equilibria() {
        for n in 1..=3 {
            let t = Transitions::between(n, Ends::Any, Ends::Any, false).unwrap();
            let m = 1usize << n;
            assert_eq!(t.len(), m * (m - 1));
            for k in 0..t.len() {
                assert_ne!(t.start(k), t.target(k));
            }
        }
        let t = Transitions::between(2, Ends::Any, Ends::Any, false).unwrap();
        assert_eq!(t.start(0), &[1.0, 1.0]);
        assert_eq!(t.target(0), &[1.0, -1.0]);
    }

    #[test]
    fn one_end_fixed_keeps_it() {
        let up = [-1.0, -1.0];
        let t = Transitions::between(2, Ends::Any, Ends::One(&up), false).unwrap();
        assert_eq!(t.len(), 3);
        assert!((0..3).all(|k| t.target(k) == up && t.start(k) != up));
        let t = Transitions::between(2, Ends::One(&up), Ends::One(&[1.0, 1.0]), false).unwrap();
        assert_eq!(t.len(), 1);
        let t = Transitions::between(2, Ends::Any, Ends::Any, true).unwrap();
        assert_eq!(t.len(), 4);
        assert!((0..4).all(|k| t.start(k) == t.target(k)));
    }

    #[test]
    fn bad_pairs_say_what_is_expected() {
        let e = Transitions::between(9, Ends::Any, Ends::Any, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("n_links") && e.contains("at most 8"), "{e}");
        let e = Transitions::between(1, Ends::One(&[1.0]), Ends::One(&[1.0]), false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("other than the target"), "{e}");
        let e = Transitions::from_pairs(2, &[(vec![1.0, 0.5], vec![1.0, 1.0])]).unwrap_err();
        assert!(e.to_string().contains("0.5"), "{e}");
        assert!(Transitions::from_pairs(2, &[]).is_err());
    }
}
