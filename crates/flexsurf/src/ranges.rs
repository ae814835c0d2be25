//! The range table of the scene format: one [`Range`] per numeric key, the only place a value's rule is
//! written. Each entry gives the key, its SI unit, its sign rule (positive, non-negative or signed), its hard
//! bounds (beyond them a value is an error: no physical scene has it, and the model's arithmetic would
//! overflow or underflow) and, for the physical fabric quantities (density, tensile and shear stiffness,
//! bending rigidity, contact stiffness and offset), the usual range of fabrics in SI and in KES-F units
//! (beyond it a value is a warning: most often a unit slip, like g/m² typed into a kg/m² key).
//!
//! The scene's checker ([`super::validate::Validator::number`]) applies an entry to a key (error or warning
//! naming the file and the key); [`crate::model::ModelBuilder`] applies only the sign rule of the same entries
//! (models built by hand in scaled units may leave the bounds). `docs/scenes.md` ("Validation ranges") lists the
//! table; a test checks that every entry is listed there.

use crate::material::units;

/// The sign a value must have (every value must also be finite).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rule {
    /// More than zero; the bounds are `(low, high)`.
    Positive,
    /// Zero or more; the bounds are `(0, high)`.
    NonNegative,
    /// Any sign; the bounds are `(−high, high)`.
    Signed,
}

/// The usual range of fabrics for a quantity, in SI and in KES-F units.
#[derive(Debug, Clone, Copy)]
pub struct Usual {
    /// Lowest and highest usual value (SI units).
    pub si: (f64, f64),
    /// The KES-F unit.
    pub kes_unit: &'static str,
    /// SI to KES-F.
    pub to_kes: fn(f64) -> f64,
}

/// One entry of the table.
#[derive(Debug, Clone, Copy)]
pub struct Range {
    /// The dotted key (`[]` for an index: `obstacle[].sphere.radius`; material keys without the `material.`
    /// prefix, as in material files).
    pub key: &'static str,
    /// SI unit (empty for a pure number).
    pub unit: &'static str,
    /// The sign rule.
    pub rule: Rule,
    /// The hard bounds `(low, high)`, both inclusive (see [`Rule`] for what `low` means).
    pub bounds: (f64, f64),
    /// The usual range of fabrics, for the physical fabric quantities.
    pub usual: Option<Usual>,
}

/// Sheet sizes, garment girths and lengths, sphere radii (m).
const LENGTH: (f64, f64) = (1e-6, 1e4);
/// Largest coordinate of a position (centres, points, heights, axes; m).
const COORDINATE: (f64, f64) = (0.0, 1e6);
/// Spring stiffness (N/m).
const SPRING: (f64, f64) = (1e-9, 1e12);
/// Tensile stiffness (N/m).
const TENSILE: (f64, f64) = (1e-6, 1e12);
/// Bending and twist rigidity (N·m).
const BENDING: (f64, f64) = (1e-15, 1e6);

const fn entry(key: &'static str, unit: &'static str, rule: Rule, bounds: (f64, f64)) -> Range {
    Range { key, unit, rule, bounds, usual: None }
}

const fn fabric(
    key: &'static str,
    unit: &'static str,
    bounds: (f64, f64),
    si: (f64, f64),
    kes_unit: &'static str,
    to_kes: fn(f64) -> f64,
) -> Range {
    Range { key, unit, rule: Rule::Positive, bounds, usual: Some(Usual { si, kes_unit, to_kes }) }
}

fn density_to_kes(v: f64) -> f64 {
    v / units::density_from_kes(1.0)
}
fn tension_to_kes(v: f64) -> f64 {
    v / units::tension_from_kes(1.0)
}
fn shear_to_kes(v: f64) -> f64 {
    v / units::shear_from_kes(1.0)
}
fn bending_to_kes(v: f64) -> f64 {
    v / units::bending_from_kes(1.0)
}
/// N/m³ to the unit of KES-F compression, gf/cm² of pressure per mm of thickness.
fn contact_to_kes(v: f64) -> f64 {
    v / (units::GF * 1e4 * 1e3)
}
/// m to mm (KES-F thickness).
fn offset_to_kes(v: f64) -> f64 {
    v * 1e3
}

/// `time.dt`.
pub const DT: Range = entry("time.dt", "s", Rule::Positive, (1e-9, 10.0));
/// `gravity`.
pub const GRAVITY: Range = entry("gravity", "m/s²", Rule::Signed, (0.0, 1e4));
/// `sheet.size`.
pub const SHEET_SIZE: Range = entry("sheet.size", "m", Rule::Positive, LENGTH);
/// `sheet.center`.
pub const SHEET_CENTER: Range = entry("sheet.center", "m", Rule::Signed, COORDINATE);
/// `sheet.rotate_deg`.
pub const SHEET_ROTATE: Range = entry("sheet.rotate_deg", "degrees", Rule::Signed, (0.0, 36_000.0));
/// `garment.waist_girth`.
pub const WAIST_GIRTH: Range = entry("garment.waist_girth", "m", Rule::Positive, LENGTH);
/// `garment.hem_girth`.
pub const HEM_GIRTH: Range = entry("garment.hem_girth", "m", Rule::Positive, LENGTH);
/// `garment.length`.
pub const GARMENT_LENGTH: Range = entry("garment.length", "m", Rule::Positive, LENGTH);
/// `garment.waist_height`.
pub const WAIST_HEIGHT: Range = entry("garment.waist_height", "m", Rule::Signed, COORDINATE);
/// `garment.axis`.
pub const GARMENT_AXIS: Range = entry("garment.axis", "m", Rule::Signed, COORDINATE);
/// `garment.waist_springs`.
pub const WAIST_SPRINGS: Range = entry("garment.waist_springs", "N/m", Rule::Positive, SPRING);
/// `obstacle[].sphere.radius`.
pub const SPHERE_RADIUS: Range = entry("obstacle[].sphere.radius", "m", Rule::Positive, LENGTH);
/// `obstacle[].sphere.center`.
pub const SPHERE_CENTER: Range = entry("obstacle[].sphere.center", "m", Rule::Signed, COORDINATE);
/// `obstacle[].plane.point`.
pub const PLANE_POINT: Range = entry("obstacle[].plane.point", "m", Rule::Signed, COORDINATE);
/// `obstacle[].plane.normal` (not zero either: checked where it is normalised).
pub const PLANE_NORMAL: Range = entry("obstacle[].plane.normal", "", Rule::Signed, COORDINATE);
/// `contact.stiffness`.
pub const CONTACT_STIFFNESS: Range = Range {
    key: "contact.stiffness",
    unit: "N/m³",
    rule: Rule::Positive,
    bounds: (1e-6, 1e15),
    usual: Some(Usual { si: (10.0, 1e8), kes_unit: "gf/cm² per mm", to_kes: contact_to_kes }),
};
/// `contact.offset`.
pub const CONTACT_OFFSET: Range = Range {
    key: "contact.offset",
    unit: "m",
    rule: Rule::NonNegative,
    bounds: (0.0, 1.0),
    usual: Some(Usual { si: (1e-4, 0.05), kes_unit: "mm", to_kes: offset_to_kes }),
};
/// `self_contact.stiffness`.
pub const SELF_STIFFNESS: Range = Range { key: "self_contact.stiffness", ..CONTACT_STIFFNESS };
/// `self_contact.thickness`.
pub const SELF_THICKNESS: Range = Range {
    key: "self_contact.thickness",
    unit: "m",
    rule: Rule::Positive,
    bounds: (1e-6, 0.1),
    usual: Some(Usual { si: (1e-4, 0.02), kes_unit: "mm", to_kes: offset_to_kes }),
};
/// `self_contact.friction`.
pub const SELF_FRICTION: Range = entry("self_contact.friction", "", Rule::NonNegative, (0.0, 100.0));
/// `self_contact.slip_speed`.
pub const SELF_SLIP_SPEED: Range = entry("self_contact.slip_speed", "m/s", Rule::Positive, (1e-9, 1e3));
/// `contact.friction`.
pub const FRICTION: Range = entry("contact.friction", "", Rule::NonNegative, (0.0, 100.0));
/// `contact.slip_speed`.
pub const SLIP_SPEED: Range = entry("contact.slip_speed", "m/s", Rule::Positive, (1e-9, 1e3));
/// `initial.velocity`: beyond sound in air no fabric is dropped.
pub const VELOCITY: Range = entry("initial.velocity", "m/s", Rule::Signed, (0.0, 1e3));
/// `initial.angular_velocity`.
pub const ANGULAR_VELOCITY: Range = entry("initial.angular_velocity", "rad/s", Rule::Signed, (0.0, 1e4));
/// `pin[].motion.turns`.
pub const MOTION_TURNS: Range = entry("pin[].motion.turns", "", Rule::Signed, (0.0, 1e4));
/// `pin[].motion.axis`.
pub const MOTION_AXIS: Range = entry("pin[].motion.axis", "", Rule::Signed, COORDINATE);
/// `pin[].motion.center`, `pin[].motion.shift`.
pub const MOTION_POINT: Range = entry("pin[].motion.center", "m", Rule::Signed, COORDINATE);
/// `pin[].motion.seconds`.
pub const MOTION_SECONDS: Range = entry("pin[].motion.seconds", "s", Rule::Positive, (1e-9, 1e9));
/// `spring[].stiffness`.
pub const SPRING_STIFFNESS: Range = entry("spring[].stiffness", "N/m", Rule::Positive, SPRING);
/// `spring[].target`.
pub const SPRING_TARGET: Range = entry("spring[].target", "m", Rule::Signed, COORDINATE);
/// `density` (of `[material]` or a material file).
pub const DENSITY: Range = fabric("density", "kg/m²", (1e-6, 1e3), (0.01, 1.5), "mg/cm²", density_to_kes);
/// `damping`.
pub const DAMPING: Range = entry("damping", "kg/(m²·s)", Rule::NonNegative, (0.0, 1e6));
/// `tensile_warp`.
pub const TENSILE_WARP: Range = fabric("tensile_warp", "N/m", TENSILE, (10.0, 1e6), "gf/cm", tension_to_kes);
/// `tensile_weft`.
pub const TENSILE_WEFT: Range = fabric("tensile_weft", "N/m", TENSILE, (10.0, 1e6), "gf/cm", tension_to_kes);
/// `shear`.
pub const SHEAR: Range = fabric("shear", "N/m", (1e-9, 1e12), (0.5, 2000.0), "gf/(cm·deg)", shear_to_kes);
/// `bending_warp`.
pub const BENDING_WARP: Range = fabric("bending_warp", "N·m", BENDING, (1e-8, 1e-3), "gf·cm²/cm", bending_to_kes);
/// `bending_weft`.
pub const BENDING_WEFT: Range = fabric("bending_weft", "N·m", BENDING, (1e-8, 1e-3), "gf·cm²/cm", bending_to_kes);
/// `twist`.
pub const TWIST: Range = entry("twist", "N·m", Rule::Positive, BENDING);
/// `poisson` (also `ν12·ν21 < 1`, checked with the other constants by [`crate::material::Fabric::validate`]).
pub const POISSON: Range = entry("poisson", "", Rule::Signed, (0.0, 1e3));
/// `bending_poisson` (also `|νb| < 1`, checked by [`crate::material::Fabric::validate`]).
pub const BENDING_POISSON: Range = entry("bending_poisson", "", Rule::Signed, (0.0, 1.0));

/// The whole table, in the order of `docs/scenes.md`.
pub const TABLE: [&Range; 41] = [
    &DT,
    &GRAVITY,
    &SHEET_SIZE,
    &SHEET_CENTER,
    &SHEET_ROTATE,
    &WAIST_GIRTH,
    &HEM_GIRTH,
    &GARMENT_LENGTH,
    &WAIST_HEIGHT,
    &GARMENT_AXIS,
    &WAIST_SPRINGS,
    &SPHERE_RADIUS,
    &SPHERE_CENTER,
    &PLANE_POINT,
    &PLANE_NORMAL,
    &CONTACT_STIFFNESS,
    &CONTACT_OFFSET,
    &SELF_STIFFNESS,
    &SELF_THICKNESS,
    &SELF_FRICTION,
    &SELF_SLIP_SPEED,
    &FRICTION,
    &SLIP_SPEED,
    &VELOCITY,
    &ANGULAR_VELOCITY,
    &MOTION_TURNS,
    &MOTION_AXIS,
    &MOTION_POINT,
    &MOTION_SECONDS,
    &SPRING_STIFFNESS,
    &SPRING_TARGET,
    &DENSITY,
    &DAMPING,
    &TENSILE_WARP,
    &TENSILE_WEFT,
    &SHEAR,
    &BENDING_WARP,
    &BENDING_WEFT,
    &TWIST,
    &POISSON,
    &BENDING_POISSON,
];

// The counts (the size of a run) are checked in `budget.rs`, against these limits.
/// Most steps of a run (`time.steps`).
pub const STEPS: usize = 1_000_000_000;
/// Most nodes of a sheet or garment (`sheet.nodes`, `garment.nodes`).
pub const NODES: usize = 100_000_000;
/// Most frames a run writes (`time.steps / time.output_every`).
pub const FRAMES: usize = 1_000_000;
/// Most steps of a garment's sewing phase (`pattern.sewing_steps`). The phase runs while the scene is built, so
/// `flexsurf check --build` and every front end's load take it: 100,000 steps is 1,000 s of sewing at
/// Δt = 0.01 s, over three hundred times the shipped garments' 300, and minutes of work on a fine pattern.
pub const SEWING_STEPS: usize = 100_000;

/// What is wrong with a position given between steps by a script (a moved pin, a spring's new target; `None`:
/// nothing): the scene's coordinate bound, ±1e6 m, as for every position a scene file gives. Beyond it the
/// squared lengths of the model's energies overflow to a NaN.
pub fn position_problem(p: crate::math::Vec3) -> Option<String> {
    let worst = [p.x, p.y, p.z].into_iter().find(|c| !c.is_finite() || c.abs() > COORDINATE.1)?;
    let bound = with_unit(format!("±{:e}", COORDINATE.1), "m");
    Some(format!("{} m is not finite or outside the accepted range {bound}", plain(worst)))
}

/// `value` with its unit (`0.01 s`, `0.3`).
pub fn with_unit(value: impl std::fmt::Display, unit: &str) -> String {
    if unit.is_empty() {
        format!("{value}")
    } else {
        format!("{value} {unit}")
    }
}

/// `x` as written, in exponent form where plain digits would run long (`-1`, `0.01`, `20000`, `1e-300`).
pub fn plain(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// `x` to three significant digits, plainly between 1e-3 and 1e5 and in exponent form beyond (`0.01`, `150`,
/// `1.02e-4`).
pub fn short(x: f64) -> String {
    let rounded: f64 = format!("{x:.2e}").parse().unwrap_or(x);
    if rounded == 0.0 || (1e-3..1e5).contains(&rounded.abs()) {
        format!("{rounded}")
    } else {
        format!("{rounded:e}")
    }
}

impl Range {
    /// The value with its unit and a space, to open a message; nothing unless `echo`.
    fn quote(&self, value: f64, echo: bool) -> String {
        if echo {
            format!("{} ", with_unit(plain(value), self.unit))
        } else {
            String::new()
        }
    }

    /// What is wrong with `value` under the sign rule alone (`None`: nothing). `echo`: the message quotes the
    /// value (not for values of files other than the scene).
    pub fn sign_problem(&self, value: f64, echo: bool) -> Option<String> {
        let quoted = self.quote(value, echo);
        match self.rule {
            Rule::NonNegative if !(value.is_finite() && value >= 0.0) => {
                Some(format!("{quoted}must be finite and non-negative"))
            }
            _ if !value.is_finite() => Some(format!("{quoted}must be a finite number")),
            // Lengths keep the wording of `[garment]`, which tests and users know.
            Rule::Positive if value <= 0.0 && self.unit == "m" => Some(format!("{quoted}must be a positive length")),
            Rule::Positive if value <= 0.0 => Some(format!("{quoted}must be positive")),
            _ => None,
        }
    }

    /// What is wrong with `value` under the sign rule and the hard bounds (`None`: nothing).
    pub fn problem(&self, value: f64, echo: bool) -> Option<String> {
        if let Some(p) = self.sign_problem(value, echo) {
            return Some(p);
        }
        let (lo, hi) = self.bounds;
        let (inside, accepted) = match self.rule {
            Rule::Positive => ((lo..=hi).contains(&value), format!("{lo:e} to {hi:e}")),
            Rule::NonNegative => (value <= hi, format!("0 to {hi:e}")),
            Rule::Signed => (value.abs() <= hi, format!("±{hi:e}")),
        };
        let quoted = self.quote(value, echo);
        (!inside).then(|| format!("{quoted}is outside the accepted range {}", with_unit(accepted, self.unit)))
    }

    /// The warning for a valid `value` outside the usual range of fabrics (`None`: usual, or no usual range).
    pub fn unusual(&self, value: f64, echo: bool) -> Option<String> {
        let u = self.usual?;
        let (lo, hi) = u.si;
        // Zero (a non-negative quantity switched off, `contact.offset = 0`) is a choice, not a unit slip.
        if value == 0.0 || (lo..=hi).contains(&value) {
            return None;
        }
        let quoted = if echo {
            format!("{}({} {}) ", self.quote(value, echo), short((u.to_kes)(value)), u.kes_unit)
        } else {
            String::new()
        };
        Some(format!(
            "{quoted}is outside the usual range of fabrics, {} to {} {} ({} to {} {} in KES units): check the units",
            short(lo),
            short(hi),
            self.unit,
            short((u.to_kes)(lo)),
            short((u.to_kes)(hi)),
            u.kes_unit
        ))
    }
}
