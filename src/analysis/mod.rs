//! The paper's analysis (Secs. III-IV) and its LQR controller, in closed form.
//!
//! * `equilibria`: the `2^n` sign tuples `s`, their names and energies.
//! * `coordinates`: the local coordinates `z = [x, C^T xi_i, xdot, C^T w_i]` of the
//!   linearisation, and the maps between them and the full nonlinear state.
//! * `linearize`: Prop. 2 (`M xdd + G x = B u`) and its first-order form `zdot = A z + B u`.
//! * `controllability`: Prop. 3 by the eigenvector (PBH) test, with a numerical margin.
//! * `riccati`: the continuous-time algebraic Riccati equation (sign function + Newton).
//! * `lyapunov`: the Lyapunov solver the Riccati polish needs.
//! * `lqr`: LQR gains in the paper's ordering and the feedback of eq. (u).
//!
//! Everything here works on small dense matrices (`2n + 2` or `4 + 4n` square) and runs
//! once per design, never in the step loop; only [`lqr::LqrController::force`] does, and it
//! allocates nothing.

mod balance;
mod checks;
mod controllability;
mod coordinates;
mod equilibria;
mod linearize;
mod lqr;
mod lyapunov;
mod pencil;
mod riccati;
mod sign;

pub use controllability::{
    controllability, controllability_with_rig, pbh_margin, pbh_margin_damped, Controllability,
    CONTROLLABILITY_THRESHOLD,
};
pub use coordinates::{local_coordinates, local_rates, state_from_local, LocalLayout};
pub use equilibria::{
    all_signs, check_signs, equilibria, index_of_signs, lowest, named_signs, signs_of_index,
    Equilibrium,
};
pub use linearize::{Linearization, StateSpace};
pub use lqr::{LqrController, LqrWeights};
pub use riccati::{solve_care, spectral_abscissa, CareSolution};
