//! Cost against the number of links: one acceleration evaluation of the O(n)
//! tension form and of the paper's dense form (eq. ELwm, an LU solve of the
//! (2+3n)-square system), and one rk4 step of the O(n) form, for n = 1 .. 256.
//!
//! `cargo run --release --example scaling [-- --quick] [-- --max-n N]`
//!
//! Prints one line per measurement, `form n seconds` (the timing is
//! `chaincart::scaling`, which `python -m chaincart_env bench --sections scaling` calls
//! through the native module). Each time is the best of three runs of at least
//! `min_time` seconds (a shared machine: the least disturbed run counts).

use chaincart::scaling::{time_form, Form};

fn arg_value(args: &[String], name: &str) -> Option<usize> {
    let at = args.iter().position(|a| a == name)?;
    args.get(at + 1).and_then(|v| v.parse().ok())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let max_n = arg_value(&args, "--max-n").unwrap_or(256);
    let min_time = if quick { 0.01 } else { 0.1 };
    let sizes = std::iter::successors(Some(1usize), |n| Some(n * 2)).take_while(|&n| n <= max_n);
    for n in sizes {
        for form in Form::ALL {
            let seconds = time_form(form, n, min_time).expect("a uniform chain on a moving state");
            println!("{} {n} {seconds:.6e}", form.name());
        }
    }
}
