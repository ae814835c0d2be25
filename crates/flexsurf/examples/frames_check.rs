//! Every written frame of a run folder through the test-side exact triangle–triangle intersection checker
//! (`flexsurf::testing::intersecting_triangles`, independent of the contact code): issue 19's "never
//! intersects" on the saved frames of a self-contact scene. `flexsurf run scenes/X.toml --out DIR`, then
//! `cargo run --release -p flexsurf --example frames_check -- DIR...`: checks the welded garment meshes
//! (`garment/*.obj`) of a garment and the frames (`frames/*.obj`) of anything else, one line per folder, and
//! exits non-zero at the first crossing.
use flexsurf::testing::{intersecting_triangles, read_obj_frame};

fn main() {
    for dir in std::env::args().skip(1).map(std::path::PathBuf::from) {
        let garment = dir.join("garment");
        let folder = if garment.is_dir() { garment } else { dir.join("frames") };
        let mut files: Vec<_> = std::fs::read_dir(&folder)
            .expect("a run folder")
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "obj"))
            .collect();
        files.sort();
        for f in &files {
            let (x, triangles) = read_obj_frame(f);
            if let Some((a, b)) = intersecting_triangles(&triangles, &x) {
                println!("{}: triangles {a} and {b} intersect", f.display());
                std::process::exit(1);
            }
        }
        println!("{}: {} frames, none with intersecting triangles", folder.display(), files.len());
    }
}
