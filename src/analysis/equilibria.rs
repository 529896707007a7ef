//! The equilibria of the uncontrolled chain (paper Sec. III-A).
//!
//! With the cart at rest every link must be vertical, so an equilibrium is a sign
//! tuple `s = (s_1..s_n)`, `s_i = +1` for a link along gravity (`q_i = e3`, hanging)
//! and `-1` for a link against it. There are `2^n` of them.
//!
//! **Order.** Equilibrium number `k` (`0 <= k < 2^n`) has `s_i = -1` exactly when bit
//! `i - 1` of `k` is set (link 1 is the least significant bit). So the order is binary
//! counting with `+1` first: index 0 is hanging, index `2^n - 1` is inverted, and for
//! n = 2 the order is (+,+), (-,+), (+,-), (-,-).

use crate::error::{InputError, Result};
use crate::geometry::Geometry;
use crate::model::Chain;

/// Full enumeration is refused above this many links: `2^20` is about a million
/// equilibria, each a state vector, which is already far more than any analysis needs.
pub const MAX_ENUMERATED_LINKS: usize = 20;

/// Names accepted by [`named_signs`].
pub const NAMES: [&str; 4] = ["hanging", "inverted", "folded", "folded_up"];

/// Checks a sign tuple: length `n`, every entry exactly `+1.0` or `-1.0`.
pub fn check_signs(s: &[f64], n: usize) -> Result<()> {
    if s.len() != n {
        return Err(InputError::LengthMismatch {
            name: "s",
            got: s.len(),
            expected: n,
        }
        .into());
    }
    match s.iter().position(|&v| v != 1.0 && v != -1.0) {
        Some(index) => Err(InputError::InvalidSign {
            index,
            value: s[index],
        }
        .into()),
        None => Ok(()),
    }
}

fn check_enumerable(n: usize) -> Result<()> {
    if n > MAX_ENUMERATED_LINKS {
        return Err(InputError::InvalidParameter {
            name: "n_links",
            value: n as f64,
            expected: "at most 20 for a full enumeration of the 2^n equilibria",
        }
        .into());
    }
    Ok(())
}

/// Sign tuple of equilibrium number `index` (see the module docs for the order).
pub fn signs_of_index(index: usize, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| if (index >> i) & 1 == 1 { -1.0 } else { 1.0 })
        .collect()
}

/// Inverse of [`signs_of_index`]; checks the tuple and refuses `n > 20`.
pub fn index_of_signs(s: &[f64]) -> Result<usize> {
    check_enumerable(s.len())?;
    check_signs(s, s.len())?;
    Ok(s.iter()
        .enumerate()
        .filter(|(_, &v)| v < 0.0)
        .map(|(i, _)| 1usize << i)
        .sum())
}

/// All `2^n` sign tuples in index order; refuses `n > 20`.
pub fn all_signs(n: usize) -> Result<Vec<Vec<f64>>> {
    check_enumerable(n)?;
    Ok((0..1usize << n).map(|k| signs_of_index(k, n)).collect())
}

/// The named equilibria: `hanging` (all +1), `inverted` (all -1), `folded`
/// (alternating, first link +1) and `folded_up` (alternating, first link -1; the
/// paper's Fig. 1 uses it for n = 5).
pub fn named_signs(name: &str, n: usize) -> Result<Vec<f64>> {
    if n == 0 {
        return Err(InputError::NoLinks.into());
    }
    let alternating = |first: f64| -> Vec<f64> {
        (0..n)
            .map(|i| if i % 2 == 0 { first } else { -first })
            .collect()
    };
    match name {
        "hanging" => Ok(vec![1.0; n]),
        "inverted" => Ok(vec![-1.0; n]),
        "folded" => Ok(alternating(1.0)),
        "folded_up" => Ok(alternating(-1.0)),
        _ => Err(InputError::UnknownName {
            kind: "equilibrium",
            name: name.to_string(),
            expected: &NAMES,
        }
        .into()),
    }
}

/// The name of a sign tuple, if it has one. Where names coincide (n = 1: hanging is
/// also folded) the first of hanging, inverted, folded, folded_up wins.
pub fn name_of(s: &[f64]) -> Option<&'static str> {
    ["hanging", "inverted", "folded", "folded_up"]
        .into_iter()
        .find(|name| named_signs(name, s.len()).is_ok_and(|t| t == s))
}

/// One equilibrium with its total energy (all potential: the chain is at rest).
#[derive(Debug, Clone, PartialEq)]
pub struct Equilibrium {
    /// Position in the enumeration order of the module docs.
    pub index: usize,
    /// The sign tuple `s` (+1 hanging link, -1 upright link).
    pub signs: Vec<f64>,
    /// Its name when it has one (`hanging`, `inverted`, `folded`, `folded_up`).
    pub name: Option<&'static str>,
    /// `Chain::energy(equilibrium(s)).total()`, i.e. `-sum_i s_i g l_i sum_{a>=i} m_a`.
    pub energy: f64,
}

/// Energy of equilibrium `s` (checked), from the model's own energy function so that
/// the two cannot disagree about the zero of the potential.
pub fn equilibrium_energy<G: Geometry>(chain: &Chain<G>, s: &[f64]) -> Result<f64> {
    let y = chain.equilibrium(s)?;
    Ok(chain.energy(&y).total())
}

/// Every equilibrium of `chain`, in index order; refuses `n > 20`.
pub fn equilibria<G: Geometry>(chain: &Chain<G>) -> Result<Vec<Equilibrium>> {
    all_signs(chain.n_links())?
        .into_iter()
        .enumerate()
        .map(|(index, signs)| {
            let energy = equilibrium_energy(chain, &signs)?;
            Ok(Equilibrium {
                index,
                name: name_of(&signs),
                signs,
                energy,
            })
        })
        .collect()
}

/// The equilibrium of least energy in a list (the hanging one, as the paper notes:
/// every upright link raises its outboard masses). `None` for an empty list.
pub fn lowest(list: &[Equilibrium]) -> Option<&Equilibrium> {
    list.iter().min_by(|a, b| a.energy.total_cmp(&b.energy))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ChainError;

    #[test]
    fn order_is_binary_counting_with_plus_first() {
        let all = all_signs(2).unwrap();
        assert_eq!(
            all,
            vec![
                vec![1.0, 1.0],
                vec![-1.0, 1.0],
                vec![1.0, -1.0],
                vec![-1.0, -1.0]
            ]
        );
        for (k, s) in all_signs(5).unwrap().iter().enumerate() {
            assert_eq!(index_of_signs(s).unwrap(), k);
        }
    }

    #[test]
    fn bad_input_is_named() {
        assert_eq!(
            check_signs(&[1.0, 0.0], 2).unwrap_err(),
            InputError::InvalidSign {
                index: 1,
                value: 0.0
            }
            .into()
        );
        assert!(matches!(
            check_signs(&[1.0], 2),
            Err(ChainError::Input(InputError::LengthMismatch { got: 1, .. }))
        ));
        let e = all_signs(21).unwrap_err().to_string();
        assert!(
            e.contains("n_links = 21") && e.contains("at most 20"),
            "{e}"
        );
        let e = named_signs("upside_down", 3).unwrap_err().to_string();
        assert!(
            e.contains("\"upside_down\"") && e.contains("folded_up"),
            "{e}"
        );
    }

    #[test]
    fn names() {
        assert_eq!(named_signs("folded", 3).unwrap(), vec![1.0, -1.0, 1.0]);
        assert_eq!(
            named_signs("folded_up", 5).unwrap(),
            vec![-1.0, 1.0, -1.0, 1.0, -1.0]
        );
        assert_eq!(name_of(&[1.0]), Some("hanging"));
        assert_eq!(name_of(&[-1.0]), Some("inverted"));
        assert_eq!(name_of(&[-1.0, 1.0]), Some("folded_up"));
        assert_eq!(name_of(&[-1.0, -1.0, 1.0]), None);
    }
}
