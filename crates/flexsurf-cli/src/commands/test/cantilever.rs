//! `flexsurf test cantilever`: the Peirce / ASTM D1388 strip of `flexsurf::lab::cantilever` hanging off a ledge;
//! prints chord angle, tip drop, bending length and implied rigidity, and writes a side view and the strip's mesh.

use super::FabricArgs;
use crate::commands::shared::print_json;
use anyhow::{bail, Context, Result};
use flexsurf::io::render;
use flexsurf::lab::cantilever::{cantilever_with_hang, length_problem, CantileverReport, Direction, Hang, Strip};
use flexsurf::math::Vec3;
use flexsurf::surface::mesh::TriMesh;
use std::path::{Path, PathBuf};

/// The arguments of `flexsurf test cantilever`: the shared ones and the strip's.
#[derive(Debug, clap::Args)]
pub struct CantileverArgs {
    #[command(flatten)]
    fabric: FabricArgs,
    /// The strip's direction (bias: 45° to warp and weft).
    #[arg(long, value_enum, default_value_t = Direction::Warp)]
    direction: Direction,
    /// Overhang in metres (default: the Peirce length 2 (K/w)^(1/3) of the input). Several, comma-separated
    /// (`--overhang 0.04,0.06,0.08`), run a sweep and chart the chord angle against the overhang.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    overhang: Vec<f64>,
    /// Strip width in metres (default 0.02).
    #[arg(long)]
    width: Option<f64>,
    /// Where to write the picture and the mesh (default out/cantilever).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `flexsurf test cantilever`.
pub fn execute(args: &CantileverArgs) -> Result<()> {
    let (fabric, name) = args.fabric.load()?;
    let calibration = args.fabric.calibration();
    let t = std::time::Instant::now();
    let (direction, width) = (args.direction, args.width);
    let out = args.out.as_deref().unwrap_or(Path::new("out/cantilever"));
    // The library's bound, checked here for every overhang of a sweep before any runs, in the flag's name.
    if let Some(p) = args.overhang.iter().find_map(|&l| length_problem(l)) {
        bail!("--overhang: {p}");
    }
    if args.overhang.len() > 1 {
        return sweep(args, &fabric, &name, calibration, out);
    }
    let overhang = args.overhang.first().copied();
    if let Some(p) = width.and_then(length_problem) {
        bail!("--width: {p}");
    }
    let strip = Strip { direction, width: width.unwrap_or(Strip::WIDTH) };
    let (r, hang) = cantilever_with_hang(&fabric, calibration, strip, overhang)
        .with_context(|| format!("cantilever test of {name}"))?;
    let seconds = t.elapsed().as_secs_f64();
    // Every number of the report must be finite (serde_json writes a non-finite one as null).
    if let Ok(serde_json::Value::Object(fields)) = serde_json::to_value(r) {
        // The rod's reference may be missing (NaN): it is said so below.
        if let Some((key, _)) = fields.iter().find(|(k, v)| v.is_null() && *k != "rod_chord_deg") {
            bail!("cantilever test of {name}: the solve gave a non-finite `{key}`");
        }
    }
    let (png, obj) = picture(&hang, &r, out)?;
    if args.fabric.json {
        let v = serde_json::json!({ "test": "cantilever", "material": name, "calibration": calibration,
            "report": r, "picture": png, "mesh": obj, "wall_seconds": seconds });
        return print_json(&v);
    }
    println!("cantilever test of {name} ({direction:?}, {calibration:?} calibration), {seconds:.3} s");
    print_report(&r, direction);
    println!("wrote {} and {}", png.display(), obj.display());
    Ok(())
}

/// The report's table (and, for the bias strip, the rod reference and the bounds of the bias rigidity).
fn print_report(r: &CantileverReport, direction: Direction) {
    println!("overhang             {:>10.4} m", r.overhang);
    println!(
        "chord angle          {:>10.3} deg (finest grid {:.3}; heavy elastica {:.3})",
        r.chord_angle_deg, r.chord_angle_fine_deg, r.elastica_deg
    );
    println!("tip drop             {:>10.4} m", r.tip_drop);
    println!("bending length c     {:>10.4} m (overhang at 41.5 deg / 2)", r.bending_length);
    println!(
        "implied rigidity w c^3 {:>10.4e} N m (input {:.4e}, {:+.2e} relative)",
        r.implied_rigidity,
        r.input_rigidity,
        r.implied_rigidity / r.input_rigidity - 1.0
    );
    if direction == Direction::Bias {
        let chord = if r.rod_chord_deg.is_finite() {
            format!("chord {:.3} deg at this overhang", r.rod_chord_deg)
        } else {
            "no chord at this overhang (its shooting finds no hanging strip this far out)".into()
        };
        println!(
            "narrow-strip reference (bend-twist coupled Kirchhoff rod): {chord}, bending length {:.4} m",
            r.rod_bending_length
        );
        println!(
            "(bias input: the free narrow strip 1/(D'^-1)_11; a wide plate would show D'_11 = {:.4e} N m;\n \
             a clamped strip of width {} m lies between, nearer the first the narrower it is)",
            r.plate_rigidity, r.width
        );
    }
}

/// Side view of the strip hanging at the report's overhang (dark) over the heavy elastica of its nominal
/// rigidity (red, set back behind it), on a ledge; and the strip's mesh. Returns (picture, mesh) paths.
fn picture(hang: &Hang, r: &CantileverReport, out: &Path) -> Result<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let mesh = hang.mesh();
    let obj = out.join("cantilever.obj");
    flexsurf::io::obj::write_obj(&obj, &mesh).with_context(|| format!("writing {}", obj.display()))?;
    let (l, w) = (r.overhang, hang.width);
    // The elastica drawn as a line along the strip's near edge.
    let reference = hang.elastica_mesh(-0.5 * w - 1e-3 * l, 0.012 * l);
    let ledge = ledge(l, w);
    let items = [
        render::Drawable::mesh(&mesh, [55, 55, 65]),
        render::Drawable::mesh(&reference, [200, 60, 50]),
        render::Drawable::mesh(&ledge, [190, 180, 160]),
    ];
    // From the −y side, a little round and above so that the strip's width shows; a narrow field of view so
    // that perspective hardly shifts the near edge against the far one.
    let target = Vec3::new(0.25 * l, 0.0, -0.35 * l);
    let (az, el) = (15f64.to_radians(), 10f64.to_radians());
    let dir = Vec3::new(-az.sin() * el.cos(), -az.cos() * el.cos(), el.sin());
    let mut view = render::View::look_at(target + dir * (10.0 * l), target);
    view.fov_y_deg = 7.0;
    view.shadows = false;
    let mut img = render::render(&view, &items, 640, 480);
    let caption = format!(
        "{:?}: dark simulated, red heavy elastica; chord {:.2} deg vs {:.2} deg",
        r.direction, r.chord_angle_deg, r.elastica_deg
    );
    render::draw_text(&mut img, 10, 10, &caption, 15.0, [30, 30, 30]);
    let png = out.join("cantilever_side.png");
    render::save_png(&png, &img).with_context(|| format!("writing {}", png.display()))?;
    Ok((png, obj))
}

/// The ledge for an overhang `l` and strip width `w`: a block under x ≤ 0, the strip's clamp on top of it.
fn ledge(l: f64, w: f64) -> TriMesh {
    let (x0, x1, y0, y1, z0, z1) = (-0.4 * l, 0.0, -w, w, -0.15 * l, -1e-3 * l);
    let corner = |k: u32| {
        Vec3::new(if k & 1 == 0 { x0 } else { x1 }, if k & 2 == 0 { y0 } else { y1 }, if k & 4 == 0 { z0 } else { z1 })
    };
    let faces: [[u32; 4]; 6] = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    TriMesh {
        positions: (0..8).map(corner).collect(),
        normals: Vec::new(),
        triangles: faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect(),
    }
}

/// `--overhang a,b,c`: the strip at each overhang, its table, and `cantilever_sweep.png` (chord angle against
/// overhang: simulated, the heavy elastica of the input rigidity, and Peirce's 41.5° of the bending length).
fn sweep(
    args: &CantileverArgs,
    fabric: &flexsurf::material::Fabric,
    name: &str,
    calibration: flexsurf::material::Calibration,
    out: &Path,
) -> Result<()> {
    use flexsurf::runner::plots::{line_chart, Series};
    let direction = args.direction;
    let strip = Strip { direction, width: args.width.unwrap_or(Strip::WIDTH) };
    let t = std::time::Instant::now();
    let mut reports = Vec::new();
    for &l in &args.overhang {
        let (r, hang) = cantilever_with_hang(fabric, calibration, strip, Some(l))
            .with_context(|| format!("cantilever test of {name} at an overhang of {l} m"))?;
        reports.push((r, hang));
    }
    let seconds = t.elapsed().as_secs_f64();
    let (png, obj) = picture(&reports[0].1, &reports[0].0, out)?;
    let chart = out.join("cantilever_sweep.png");
    let cm = |r: &CantileverReport| 100.0 * r.overhang;
    let series = [
        Series {
            name: "simulated".into(),
            color: [31, 119, 180],
            points: reports.iter().map(|(r, _)| (cm(r), r.chord_angle_deg)).collect(),
            dots: true,
        },
        Series {
            name: "heavy elastica (input rigidity)".into(),
            color: [214, 39, 40],
            points: reports.iter().map(|(r, _)| (cm(r), r.elastica_deg)).collect(),
            dots: true,
        },
        Series {
            name: "41.5 deg (Peirce: overhang = 2 c)".into(),
            color: [120, 120, 120],
            points: vec![(cm(&reports[0].0), 41.5), (cm(&reports[reports.len() - 1].0), 41.5)],
            dots: false,
        },
    ];
    let title = format!("Cantilever of {name} ({direction:?}): chord angle vs overhang");
    line_chart(&chart, (760, 460), &title, "overhang (cm)", "chord angle (deg)", &series)
        .with_context(|| format!("writing {}", chart.display()))?;
    if args.fabric.json {
        let list: Vec<_> = reports.iter().map(|(r, _)| r).collect();
        let v = serde_json::json!({ "test": "cantilever", "material": name, "calibration": calibration,
            "reports": list, "picture": png, "mesh": obj, "chart": chart, "wall_seconds": seconds });
        return print_json(&v);
    }
    println!("cantilever sweep of {name} ({direction:?}, {calibration:?} calibration), {seconds:.3} s");
    println!(
        "{:>10} {:>12} {:>14} {:>10} {:>16}",
        "overhang m", "chord deg", "elastica deg", "tip drop m", "bending length m"
    );
    for (r, _) in &reports {
        println!(
            "{:>10.4} {:>12.3} {:>14.3} {:>10.4} {:>16.4}",
            r.overhang, r.chord_angle_deg, r.elastica_deg, r.tip_drop, r.bending_length
        );
    }
    println!("wrote {} (the first overhang), {} and {}", png.display(), obj.display(), chart.display());
    Ok(())
}
