//! The fixed-step classical Runge–Kutta integrator of the cantilever's references (the planar heavy
//! [`Elastica`](super::Elastica) and the Kirchhoff rod, [`rod_chord_deg`](super::rod_chord_deg)): one generic
//! step over any state made of `f64` components ([`OdeState`]: a number, or arrays of states).

/// A state the integrator can advance: its components can be combined one by one with those of other states of
/// the same shape.
pub trait OdeState: Copy {
    /// The state whose every component is `f(own component, [the same component of each of ks])`.
    fn zip<const K: usize, F: Fn(f64, [f64; K]) -> f64>(&self, ks: [&Self; K], f: &F) -> Self;
}

impl OdeState for f64 {
    fn zip<const K: usize, F: Fn(f64, [f64; K]) -> f64>(&self, ks: [&Self; K], f: &F) -> Self {
        f(*self, ks.map(|k| *k))
    }
}

impl<S: OdeState, const N: usize> OdeState for [S; N] {
    fn zip<const K: usize, F: Fn(f64, [f64; K]) -> f64>(&self, ks: [&Self; K], f: &F) -> Self {
        std::array::from_fn(|i| self[i].zip(ks.map(|k| &k[i]), f))
    }
}

/// Integrates `y' = rhs(s, y)` from `y(0) = y0` over `steps` steps of length `h` (classical RK4, `s = i h` at
/// the start of step `i`), calling `each` with the state after every step; returns the final state.
/// Per component the update is `y + h/6 (k1 + 2 k2 + 2 k3 + k4)`, with the stages taken at `y + (h/2) k`.
pub fn rk4<S: OdeState>(y0: S, h: f64, steps: usize, rhs: impl Fn(f64, &S) -> S, mut each: impl FnMut(&S)) -> S {
    let mut y = y0;
    for i in 0..steps {
        let s = i as f64 * h;
        let k1 = rhs(s, &y);
        let k2 = rhs(s + 0.5 * h, &y.zip([&k1], &|y, [k]| y + 0.5 * h * k));
        let k3 = rhs(s + 0.5 * h, &y.zip([&k2], &|y, [k]| y + 0.5 * h * k));
        let k4 = rhs(s + h, &y.zip([&k3], &|y, [k]| y + h * k));
        y = y.zip([&k1, &k2, &k3, &k4], &|y, [k1, k2, k3, k4]| y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4));
        each(&y);
    }
    y
}
