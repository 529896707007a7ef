//! The named scenes: each a set of values on top of the key defaults of
//! [`super::keys::CONFIG_KEYS`] (which are the default scene's), applied in order.

pub use super::keys::DEFAULT_SCENE;
use super::keys::{config_key, KeyValue};
use crate::error::{InputError, Result};
use crate::params::{PAPER_CART_MASS, PAPER_LINKS, PAPER_LINK_LENGTH, PAPER_LINK_MASS};
use std::sync::LazyLock;

/// A named scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scene {
    /// Its name.
    pub name: &'static str,
    /// What it is, in one line (for the documentation's scene table).
    pub summary: &'static str,
    /// Groups of `(key, value)` on top of the defaults; a later value wins.
    pub values: &'static [&'static [(&'static str, KeyValue)]],
}

/// The single planar inverted pendulum, a CartPole-sized one: a point mass of 0.1 kg at
/// 0.5 m on a 1 kg cart, unstable at about 4.6 1/s.
const SINGLE: &[(&str, KeyValue)] = &[
    ("n_links", KeyValue::Int(1)),
    ("max_force", KeyValue::Float(10.0)),
];

/// The paper's system (spatial, 5 links, 0.5 kg cart, 0.1 kg and 0.1 m links),
/// starting exactly at the figure's initial condition, with room for the paper's forces.
const PAPER: &[(&str, KeyValue)] = &[
    ("n_links", KeyValue::Int(PAPER_LINKS as i64)),
    ("cart_mass", KeyValue::Float(PAPER_CART_MASS)),
    ("link_masses", KeyValue::Float(PAPER_LINK_MASS)),
    ("link_lengths", KeyValue::Float(PAPER_LINK_LENGTH)),
    ("planar", KeyValue::Bool(false)),
    ("start_noise", KeyValue::Float(0.0)),
    ("max_force", KeyValue::Float(100.0)),
    ("track_limit", KeyValue::Float(10.0)),
];

/// Cart mass and each link's mass and length redrawn within +-25 % of the model's at
/// every reset.
const RANDOMIZED: &[(&str, KeyValue)] = &[(
    "randomize",
    KeyValue::Relative(&[
        ("cart_mass", 0.25),
        ("link_masses", 0.25),
        ("link_lengths", 0.25),
    ]),
)];

/// Gaussian sensor noise (0.01 in every state component: 1 cm, 0.01 rad, 0.01 m/s,
/// 0.01 rad/s) and a one-period (20 ms) control delay.
const NOISY: &[(&str, KeyValue)] = &[
    ("obs_noise", KeyValue::Float(0.01)),
    ("action_delay", KeyValue::Int(1)),
];

/// Cart in the plane, links on spherical joints.
const SPATIAL: &[(&str, KeyValue)] = &[("planar", KeyValue::Bool(false))];

/// Large motions of the default scene's system: the bounded reward, success only after
/// a second held within the tolerances, a 3 m track and 20 N. The planner plans and its
/// time-varying LQR tracks every transition of two links within these limits in at
/// most 4 s (docs/tasks.md), so an episode of 6 s leaves room for the hold.
const LARGE_MOTION: &[(&str, KeyValue)] = &[
    ("reward", KeyValue::Name("tolerance")),
    ("success_hold", KeyValue::Float(1.0)),
    ("track_limit", KeyValue::Float(3.0)),
    ("max_force", KeyValue::Float(20.0)),
    ("max_episode_steps", KeyValue::Int(300)),
];

/// Three links: 30 N and 10 s episodes (the planner's swing-up takes 8 s at 30 N; at
/// 6 s it finds none).
const THREE_LINKS: &[(&str, KeyValue)] = &[
    ("n_links", KeyValue::Int(3)),
    ("max_force", KeyValue::Float(30.0)),
    ("max_episode_steps", KeyValue::Int(500)),
];

/// Goal-conditioned: every reset draws a start and a different target among all
/// equilibria; the observation ends with the target's signs.
const ANY_TRANSITION: &[(&str, KeyValue)] = &[
    ("start", KeyValue::Name("any")),
    ("target", KeyValue::Name("any")),
    ("goal_observation", KeyValue::Bool(true)),
];

/// A linear cart driven by a DC motor through a gearbox and a rack and pinion, with the
/// values published for Quanser's IP02 cart (docs/sim-to-real.md, "Scenes of real
/// rigs", gives the sources and marks the assumed values): 0.57 kg, motor `R = 2.6`
/// ohm, gearbox 3.71, pinion radius 6.4 mm, viscous friction 4.3 N s/m as seen at the
/// pinion; the torque constant 0.00767 N m/A, the 4 A current limit and the 6 V
/// command are assumptions.
const MOTOR_CART: &[(&str, KeyValue)] = &[
    ("cart_mass", KeyValue::Float(0.57)),
    ("cart_viscous_friction", KeyValue::Float(4.3)),
    ("actuation", KeyValue::Name("voltage")),
    ("max_voltage", KeyValue::Float(6.0)),
    (
        "motor",
        KeyValue::Floats(&[0.00767, 2.6, 3.71, 0.0064, 4.0]),
    ),
];

/// Every scene, in documentation order.
pub const SCENES: &[Scene] = &[
    // A CartPole-sized planar inverted pendulum. PPO solves it in seconds.
    Scene {
        name: "inverted-1",
        summary: "planar, 1 link (CartPole-sized, unstable at about 4.6/s): keep it upright from +-0.05 noise",
        values: &[SINGLE],
    },
    // The default: the planar double inverted pendulum, two such links. LQR holds it
    // from +-0.05 noise; PPO (SB3 defaults, 8 envs) needs a few hundred thousand steps,
    // about a minute and a half on two cores: a PPO-vs-LQR comparison with a learning
    // curve that fits in five minutes. Its values are the key defaults.
    Scene {
        name: "inverted-2",
        summary: "planar double inverted pendulum (1 kg cart, 0.1 kg at the end of each 0.5 m link): keep both links upright from +-0.05 noise",
        values: &[],
    },
    // Swing-up of the planar single pendulum from hanging.
    Scene {
        name: "swingup-1",
        summary: "as inverted-1: swing it up from hanging",
        values: &[
            SINGLE,
            &[
                ("start", KeyValue::Name("hanging")),
                ("track_limit", KeyValue::Float(3.0)),
            ],
        ],
    },
    // Large motions: swing-up of two and three links, and goal-conditioned transitions
    // between any two equilibria.
    Scene {
        name: "swingup-2",
        summary: "as inverted-2: swing both links up from hanging (20 N, 3 m track, 6 s, held 1 s, bounded reward)",
        values: &[LARGE_MOTION, &[("start", KeyValue::Name("hanging"))]],
    },
    Scene {
        name: "swingup-3",
        summary: "the planar triple pendulum (0.1 kg, 0.5 m links): swing all three up from hanging (30 N, 3 m, 10 s, held 1 s)",
        values: &[
            LARGE_MOTION,
            THREE_LINKS,
            &[("start", KeyValue::Name("hanging"))],
        ],
    },
    Scene {
        name: "spatial-swingup-2",
        summary: "as swingup-2, with spherical joints and the cart in the plane",
        values: &[
            LARGE_MOTION,
            SPATIAL,
            &[("start", KeyValue::Name("hanging"))],
        ],
    },
    Scene {
        name: "transitions-2",
        summary: "goal-conditioned, two links: each episode from a drawn equilibrium to a different drawn one (12 pairs), the target's signs observed",
        values: &[LARGE_MOTION, ANY_TRANSITION],
    },
    Scene {
        name: "transitions-3",
        summary: "goal-conditioned, three links: 56 pairs of equilibria (30 N, 3 m, 10 s), the target's signs observed",
        values: &[LARGE_MOTION, THREE_LINKS, ANY_TRANSITION],
    },
    // The paper's figures are continuous-time results: their scenes hold the force for
    // at most 1 ms. Fig. 1: uncontrolled (max_force 0: every action is ignored) motion
    // from IC1 near the folded equilibrium s = (-1, 1, -1, 1, -1), scored against it;
    // RK4 at 1 ms is accurate to about a millimetre over 1 s (docs/performance.md,
    // speed vs accuracy).
    Scene {
        name: "paper-fig1",
        summary: "the paper's system (spatial, 5 links, 0.5 kg cart, 0.1 kg and 0.1 m links): uncontrolled from IC1 near the folded equilibrium (-1,1,-1,1,-1), scored against it",
        values: &[
            PAPER,
            &[
                ("target", KeyValue::Name("paper-fig1")),
                ("start", KeyValue::Name("paper-fig1")),
                ("max_force", KeyValue::Float(0.0)),
                ("dt", KeyValue::Float(1e-3)),
                ("substeps", KeyValue::Int(1)),
                ("max_episode_steps", KeyValue::Int(10_000)),
            ],
        ],
    },
    // Fig. 2: stabilise the hanging equilibrium from IC1. The chain falls from the folded
    // start far outside the linear region; the LQR catches it when the force is held
    // for 0.3 ms or less (a 1 ms hold pumps energy into the fast modes), so 0.1 ms.
    // e_q and e_w stay below 1e-3 from 9.2 s.
    Scene {
        name: "paper-fig2",
        summary: "the paper's system: stabilise hanging from IC1 (the LQR catches the falling chain only with a force hold of 0.3 ms or less)",
        values: &[
            PAPER,
            &[
                ("target", KeyValue::Name("hanging")),
                ("start", KeyValue::Name("paper-fig2")),
                ("dt", KeyValue::Float(1e-4)),
                ("substeps", KeyValue::Int(1)),
                ("max_episode_steps", KeyValue::Int(100_000)),
            ],
        ],
    },
    // Fig. 3: stabilise s = (-1, -1, -1, 1, 1) from the Fig. 3 initial condition. With
    // the paper's weights the slowest closed-loop poles are -0.77 +- 0.56i: e_q and e_w
    // fall below 1e-3 at 11.3 s, so the episode lasts 12 s.
    Scene {
        name: "paper-fig3",
        summary: "the paper's system: stabilise (-1,-1,-1,1,1) from the Fig. 3 initial condition (it settles at 11.3 s)",
        values: &[
            PAPER,
            &[
                ("target", KeyValue::Name("paper-fig3")),
                ("start", KeyValue::Name("paper-fig3")),
                ("dt", KeyValue::Float(1e-3)),
                ("substeps", KeyValue::Int(1)),
                ("max_episode_steps", KeyValue::Int(12_000)),
            ],
        ],
    },
    // Sim-to-real scenes on the default double inverted pendulum. "-randomized": a
    // controller designed on the model meets a different system in every episode.
    // "-noisy": a noisy, late sensor.
    Scene {
        name: "inverted-2-randomized",
        summary: "as inverted-2: cart mass, link masses and lengths redrawn within +-25% at every reset",
        values: &[RANDOMIZED],
    },
    Scene {
        name: "inverted-2-noisy",
        summary: "as inverted-2: observation noise 0.01 and a one-step control delay",
        values: &[NOISY],
    },
    // Rigs: an actuation other than a force, and damping and friction the ideal model
    // lacks. The LQR (designed with the rig) holds both; the planners refuse them.
    Scene {
        name: "inverted-2-motor",
        summary: "double inverted pendulum on a voltage-driven linear cart (IP02-like motor, gearbox and friction; 0.23 kg at 0.33 m, 0.127 kg at 0.18 m, joint damping 0.0024 N m s/rad): keep both links upright, 6 V",
        values: &[
            MOTOR_CART,
            &[
                ("link_masses", KeyValue::Floats(&[0.230, 0.127])),
                ("link_lengths", KeyValue::Floats(&[0.3302, 0.1778])),
                ("joint_damping", KeyValue::Float(0.0024)),
                ("dt", KeyValue::Float(0.01)),
                ("track_limit", KeyValue::Float(0.4)),
            ],
        ],
    },
    Scene {
        name: "inverted-3-servo",
        summary: "planar triple inverted pendulum on an acceleration-driven cart (a servo axis, as in triple-pendulum rigs; 0.1 kg, 0.3 m links, joint damping 0.001 N m s/rad): keep all three upright from +-0.02 noise, 20 m/s^2",
        values: &[
            THREE_LINKS,
            &[
                ("link_lengths", KeyValue::Float(0.3)),
                ("joint_damping", KeyValue::Float(0.001)),
                ("actuation", KeyValue::Name("acceleration")),
                ("max_acceleration", KeyValue::Float(20.0)),
                ("dt", KeyValue::Float(0.01)),
                // From +-0.05 the LQR runs off the 2.4 m track in half the episodes.
                ("start_noise", KeyValue::Float(0.02)),
            ],
        ],
    },
    // The same three on the spatial double pendulum.
    Scene {
        name: "spatial-inverted-2",
        summary: "as inverted-2, with spherical joints and the cart in the plane",
        values: &[SPATIAL],
    },
    Scene {
        name: "spatial-inverted-2-randomized",
        summary: "as inverted-2-randomized, with spherical joints",
        values: &[SPATIAL, RANDOMIZED],
    },
    Scene {
        name: "spatial-inverted-2-noisy",
        summary: "as inverted-2-noisy, with spherical joints",
        values: &[SPATIAL, NOISY],
    },
];

/// The scene names, in the order of [`SCENES`], for error messages.
pub static SCENE_NAMES: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| SCENES.iter().map(|s| s.name).collect());

impl Scene {
    /// The scene with this name, or an error listing the scenes.
    pub fn named(name: &str) -> Result<&'static Scene> {
        SCENES.iter().find(|s| s.name == name).ok_or_else(|| {
            InputError::UnknownName {
                kind: "scene",
                name: name.to_string(),
                expected: SCENE_NAMES.as_slice(),
            }
            .into()
        })
    }

    /// The scene's value of `key`: its own if it sets one, else the key's default
    /// (`None` for an unknown key).
    pub fn value(&self, key: &str) -> Option<KeyValue> {
        if key == "scene" {
            return Some(KeyValue::Name(self.name));
        }
        let own = self
            .values
            .iter()
            .rev()
            .flat_map(|group| group.iter().rev())
            .find(|(k, _)| *k == key)
            .map(|&(_, v)| v);
        own.or_else(|| config_key(key).map(|k| k.default))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::keys::CONFIG_KEYS;

    #[test]
    fn scenes_set_only_known_keys_and_have_unique_names() {
        for scene in SCENES {
            for (key, _) in scene.values.iter().flat_map(|g| g.iter()) {
                assert!(config_key(key).is_some(), "{}: {key}", scene.name);
            }
        }
        let mut names = SCENE_NAMES.clone();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), SCENES.len());
    }

    #[test]
    fn the_default_scene_is_the_key_defaults() {
        let scene = Scene::named(DEFAULT_SCENE).unwrap();
        for key in CONFIG_KEYS.iter().filter(|k| k.name != "scene") {
            assert_eq!(scene.value(key.name), Some(key.default), "{}", key.name);
        }
        assert_eq!(
            Scene::named("paper-fig2").unwrap().value("dt"),
            Some(KeyValue::Float(1e-4))
        );
    }

    #[test]
    fn an_unknown_scene_names_itself_and_the_scenes() {
        let e = Scene::named("cartpole").unwrap_err().to_string();
        assert!(
            e.contains("\"cartpole\"") && e.contains("\"paper-fig3\""),
            "{e}"
        );
    }
}
