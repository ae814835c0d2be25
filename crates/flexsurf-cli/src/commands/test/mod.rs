//! `flexsurf test`: the virtual textile tests of `flexsurf::lab` as typed subcommands, one module each
//! ([`kes`], [`cantilever`], [`cusick`]). Each takes the options they all share ([`FabricArgs`]: the material,
//! the calibration and `--json`, flattened into it) and only its own; this module holds those shared options and
//! the dispatch.

pub mod cantilever;
pub mod cusick;
pub mod kes;

use anyhow::Result;
use clap::Subcommand;
use flexsurf::material::law::Laws;
use flexsurf::material::{Calibration, Fabric};
use std::path::PathBuf;

/// The virtual tests.
#[derive(Debug, Subcommand)]
pub enum TestCommand {
    /// KES: tension (warp, weft, 45° bias), simple shear and pure bending (warp, weft) on small specimens, solved
    /// to equilibrium; prints the recovered constants and their errors.
    Kes(kes::KesArgs),
    /// The Peirce / ASTM D1388 strip hanging off a ledge; chord angle, tip drop, bending length.
    Cantilever(cantilever::CantileverArgs),
    /// The Cusick drape meter (18 cm disc); drape coefficient, nodes, a top-view picture and the mesh.
    Cusick(cusick::CusickArgs),
}

/// The options every virtual test takes.
#[derive(Debug, clap::Args)]
pub struct FabricArgs {
    /// Material file (materials/*.toml, SI or KES units); default the paper's non-woven cotton.
    #[arg(long)]
    material: Option<PathBuf>,
    /// Calibration of the energy coefficients.
    #[arg(long, value_enum, default_value_t = Calibration::Kes)]
    calibration: Calibration,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

impl FabricArgs {
    /// The fabric of `--material FILE`, or the paper's non-woven cotton, with its display name. A material with
    /// curves is refused: these tests run its linear constants only (`test kes` and runs use the curves).
    fn load(&self) -> Result<(Fabric, String)> {
        let (fabric, laws, name) = self.load_with_laws()?;
        anyhow::ensure!(
            laws.is_empty(),
            "{name}: this virtual test does not use nonlinear curves yet (`flexsurf test kes` and scene runs do)"
        );
        Ok((fabric, name))
    }

    /// As [`FabricArgs::load`] with the material's nonlinear laws (empty for a linear one).
    fn load_with_laws(&self) -> Result<(Fabric, Laws, String)> {
        Ok(match &self.material {
            Some(path) => {
                let m = flexsurf::scene::material::load_material_file(path)?;
                // Constants outside the usual range of fabrics (a unit slip, most often), as a run says them.
                super::shared::print_warnings(&m.warnings);
                (m.fabric, m.laws, m.name)
            }
            None => (Fabric::paper_cotton(), Laws::default(), "paper-cotton".to_string()),
        })
    }

    /// The chosen calibration.
    fn calibration(&self) -> Calibration {
        self.calibration
    }
}

/// `flexsurf test <kes|cantilever|cusick>`.
pub fn execute(test: &TestCommand) -> Result<()> {
    match test {
        TestCommand::Kes(args) => kes::execute(args),
        TestCommand::Cantilever(args) => cantilever::execute(args),
        TestCommand::Cusick(args) => cusick::execute(args),
    }
}
