//! Scenes of several sheets (issue 18): `[[sheet]]` tables build one panel each, in node order; pins and
//! springs name their sheet; errors name `sheet[k]`; the single `[sheet]` table keeps working.

use flexsurf::math::Vec3;
use flexsurf::scene::SceneSpec;
use flexsurf::testing::repo;
use std::path::Path;

const TWO: &str = r#"
name = "two"
[[sheet]]
size = [0.4, 0.4]
nodes = [9, 9]
center = [0.0, 0.0, 0.5]
[[sheet]]
size = [0.3, 0.2]
nodes = [7, 5]
center = [1.0, 0.0, 0.5]
rotate_deg = [0.0, 0.0, 90.0]
[time]
steps = 10
"#;

fn build(text: &str) -> Result<flexsurf::scene::Scene, flexsurf::scene::SceneError> {
    let file = Path::new("two.toml");
    SceneSpec::from_toml(text, file)?.build(file)
}

#[test]
fn each_sheet_is_a_panel_in_node_order() {
    let scene = build(TWO).unwrap();
    let model = &scene.model;
    assert_eq!(model.panels.len(), 2);
    assert_eq!((model.panels[0].grid.m, model.panels[0].grid.n), (9, 9));
    assert_eq!((model.panels[1].grid.m, model.panels[1].grid.n, model.panels[1].global(0)), (7, 5, 81));
    assert_eq!(model.nodes(), 81 + 35);
    // The second sheet's first corner: (−0.15, −0.1) of its pattern turned 90° about z, about its centre.
    let corner = scene.state.x[81];
    assert!((corner - Vec3::new(1.1, -0.15, 0.5)).length() < 1e-12, "corner at {corner}");
    // Both sheets carry their own mass: ρ × area.
    let density = model.fabric.density;
    assert!((model.total_mass() - density * (0.16 + 0.06)).abs() < 1e-12);
}

#[test]
fn pins_and_springs_name_their_sheet() {
    let text = format!(
        "{TWO}\n[[pin]]\nsheet = 1\nnodes = [[0, 0]]\n[[pin]]\nnodes = [[8, 8]]\n[[spring]]\nsheet = 1\nset = \"corners\"\nstiffness = 5.0\n"
    );
    let scene = build(&text).unwrap();
    let pinned: Vec<usize> = (0..scene.model.nodes()).filter(|&k| scene.model.pinned()[k]).collect();
    assert_eq!(pinned, vec![80, 81]);
    let springs: Vec<usize> = scene.model.springs().iter().map(|s| s.node).collect();
    assert_eq!(springs, vec![81, 81 + 6, 81 + 28, 81 + 34]);
}

#[test]
fn errors_name_the_sheet() {
    let e = build(&format!("{TWO}\n[[pin]]\nsheet = 2\nset = \"all\"\n")).unwrap_err().to_string();
    assert!(e.contains("pin[0].sheet") && e.contains("sheet 2 does not exist"), "{e}");
    let e = build(&TWO.replace("nodes = [7, 5]", "nodes = [7, 2]")).unwrap_err().to_string();
    assert!(e.contains("sheet[1].nodes"), "{e}");
    let e = build(&TWO.replace("size = [0.3, 0.2]", "size = [0.3, -0.2]")).unwrap_err().to_string();
    assert!(e.contains("sheet[1].size"), "{e}");
    let e = build(&TWO.replace("nodes = [9, 9]", "nodes = [9, 9]\nsides = 3")).unwrap_err().to_string();
    assert!(e.contains("sides"), "an unknown key inside a [[sheet]] is reported: {e}");
}

#[test]
fn the_single_sheet_table_keeps_working() {
    let path = repo().join("scenes/ball_drop.toml");
    let spec = SceneSpec::load(&path).unwrap();
    assert!(matches!(spec.sheet, Some(flexsurf::scene::Sheets::One(_))));
    let scene = spec.build(&path).unwrap();
    assert_eq!(scene.model.panels.len(), 1);
    let shipped = SceneSpec::load(&repo().join("scenes/two_sheets.toml")).unwrap();
    assert_eq!(shipped.sheet.as_ref().map(|s| s.list().len()), Some(2));
}
