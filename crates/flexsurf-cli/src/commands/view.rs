//! `flexsurf view`: writes `OUT_DIR/view.html`, the self-contained interactive viewer of a run folder
//! (`flexsurf::runner::viewer`), and says how to open it; `--gif` and `--mp4` add a movie of the run; `--serve`
//! serves it on the loopback interface ([`serve`]).

use anyhow::{bail, Context, Result};
use flexsurf::runner::viewer::{self, movie};
use std::path::PathBuf;
use std::process::Command;

mod serve;

/// The arguments of `flexsurf view`.
#[derive(Debug, clap::Args)]
pub struct ViewArgs {
    /// A run folder (the `--out` of `flexsurf run`, or `out/demo/tfs` after `flexsurf demo`).
    dir: PathBuf,
    /// Also write OUT_DIR/animation.gif: the shaded run at real speed (pictures blended between frames).
    #[arg(long)]
    gif: bool,
    /// Also write OUT_DIR/animation.mp4 (needs `ffmpeg` on the PATH).
    #[arg(long)]
    mp4: bool,
    /// Movie pictures per simulated second.
    #[arg(long, default_value_t = 10.0)]
    fps: f64,
    /// Movie picture size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "480x360", value_parser = parse_size)]
    size: (u32, u32),
    /// After writing the page, serve it on the loopback interface (127.0.0.1 only), following a running
    /// simulation: the page reloads when the run writes a frame or finishes. Stop with Ctrl-C.
    #[arg(long)]
    serve: bool,
    /// Port for --serve (0: any free port; the address is printed).
    #[arg(long, default_value_t = 8765)]
    port: u16,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once('x').ok_or_else(|| format!("{s:?}: expected WIDTHxHEIGHT, e.g. 480x360"))?;
    let p = |v: &str| v.trim().parse::<u32>().ok().filter(|&n| (16..=4096).contains(&n));
    match (p(w), p(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("{s:?}: width and height must be whole numbers from 16 to 4096")),
    }
}

/// `flexsurf view`.
pub fn execute(args: &ViewArgs) -> Result<()> {
    if !(args.fps.is_finite() && args.fps > 0.0 && args.fps <= 120.0) {
        bail!("--fps: {} must be more than 0 and at most 120 pictures per simulated second", args.fps);
    }
    let ffmpeg = args.mp4.then(|| Command::new("ffmpeg").arg("-version").output().is_ok_and(|o| o.status.success()));
    if ffmpeg == Some(false) {
        bail!(
            "--mp4 needs ffmpeg on the PATH, and there is none (Debian: apt-get install ffmpeg); --gif needs nothing \
             else"
        );
    }
    let path =
        viewer::write_view(&args.dir).with_context(|| format!("writing the viewer of {}", args.dir.display()))?;
    let size = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    println!("wrote {} ({:.1} MB); open it in a browser (it needs no network)", path.display(), size as f64 / 1e6);
    if args.gif {
        let gif = movie::write_gif(&args.dir, args.fps, args.size)
            .with_context(|| format!("writing the GIF of {}", args.dir.display()))?;
        println!("wrote {}", gif.display());
    }
    if args.serve {
        return serve::serve(&args.dir, args.port);
    }
    if args.mp4 {
        let frames = args.dir.join(".mp4-pictures");
        let n = movie::write_pictures(&args.dir, &frames, args.fps, args.size)
            .with_context(|| format!("writing the movie pictures of {}", args.dir.display()))?;
        let mp4 = args.dir.join("animation.mp4");
        // ffmpeg writes a temporary sibling, renamed into place when it succeeded.
        let tmp = args.dir.join(".animation.tmp.mp4");
        let status = Command::new("ffmpeg")
            .args(["-loglevel", "error", "-y", "-framerate"])
            .arg(format!("{}", args.fps))
            .arg("-i")
            .arg(frames.join("frame_%05d.png"))
            .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", "-c:v", "libx264"])
            .arg(&tmp)
            .status();
        let _ = std::fs::remove_dir_all(&frames);
        match status {
            Ok(s) if s.success() => {
                std::fs::rename(&tmp, &mp4)
                    .with_context(|| format!("renaming {} to {}", tmp.display(), mp4.display()))?;
                println!("wrote {} ({n} pictures)", mp4.display());
            }
            Ok(s) => {
                let _ = std::fs::remove_file(&tmp);
                bail!("ffmpeg failed ({s}) writing {}", mp4.display())
            }
            Err(e) => bail!("could not start ffmpeg: {e}"),
        }
    }
    Ok(())
}
