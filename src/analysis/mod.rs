//! The paper's analysis (Secs. III-IV) and its LQR controller, in closed form.
//!
//! * [`mod@equilibria`]: the `2^n` sign tuples `s`, their names and energies.
//! * [`coordinates`]: the local coordinates `z = [x, C^T xi_i, xdot, C^T w_i]` of the
//!   linearisation, and the maps between them and the full nonlinear state.
//! * [`linearize`]: Prop. 2 (`M xdd + G x = B u`) and its first-order form `zdot = A z + B u`.
//! * [`mod@controllability`]: Prop. 3 by the eigenvector (PBH) test, with a numerical margin.
//! * [`riccati`]: the continuous-time algebraic Riccati equation (sign function + Newton).
//! * [`lyapunov`]: the Lyapunov solver the Riccati polish needs.
//! * [`lqr`]: LQR gains in the paper's ordering and the feedback of eq. (u).
//!
//! Everything here works on small dense matrices (`2n + 2` or `4 + 4n` square) and runs
//! once per design, never in the step loop; only [`lqr::LqrController::force`] does, and it
//! allocates nothing.

pub mod balance;
pub mod checks;
pub mod controllability;
pub mod coordinates;
pub mod equilibria;
pub mod linearize;
pub mod lqr;
pub mod lyapunov;
pub mod pencil;
pub mod riccati;
pub mod sign;

pub use controllability::{controllability, pbh_margin, Controllability};
pub use coordinates::LocalLayout;
pub use equilibria::{all_signs, check_signs, equilibria, named_signs, Equilibrium};
pub use linearize::{Linearization, StateSpace};
pub use lqr::{LqrController, LqrWeights};
pub use riccati::{solve_care, CareSolution};
