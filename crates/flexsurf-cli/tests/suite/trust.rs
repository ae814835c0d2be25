//! Issue 22, "trust boundaries", at the command line: `view --serve` under idle, oversized and misdirected
//! connections (loopback only, a bounded number of connections, each with a deadline), `view` of a FIFO,
//! and two `run` processes into one folder.
use flexsurf::testing::repo;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_flexsurf");

fn scratch(tag: &str) -> flexsurf::testing::ScratchDir {
    flexsurf::testing::scratch("cli-trust", tag)
}

/// A small, quick copy of the ball drop (9 × 9 nodes) with `steps` steps, written into `dir`.
fn drop_scene(dir: &Path, steps: usize) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("scenes/ball_drop.toml")).unwrap();
    let text = text
        .replace("nodes = [21, 21]", "nodes = [9, 9]")
        .replace("steps = 300", &format!("steps = {steps}"))
        .replace("image_size = [480, 360]", "image_size = [64, 48]");
    let path = dir.join("drop.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn flexsurf(args: &[&str]) -> (i32, String) {
    let o = Command::new(BIN).args(args).output().unwrap();
    (o.status.code().unwrap_or(-1), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// A run folder with a finished run in it, and its scratch folder (removed when dropped).
fn run_folder(tag: &str) -> (flexsurf::testing::ScratchDir, PathBuf) {
    let d = scratch(tag);
    let scene = drop_scene(&d, 20);
    let out = d.join("out");
    let (code, err) = flexsurf(&["run", scene.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    (d, out)
}

/// `flexsurf view DIR --serve --port 0`, killed when dropped; `port` is the one it printed.
struct Server {
    child: Child,
    port: u16,
}

impl Server {
    fn start(dir: &Path) -> Self {
        let mut child = Command::new(BIN)
            .args(["view", dir.to_str().unwrap(), "--serve", "--port", "0"])
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let mut stdout = child.stdout.take().unwrap();
        let mut text = String::new();
        let mut byte = [0u8; 1];
        // "serving http://127.0.0.1:PORT/ …" follows the "wrote …" line.
        while !text.contains("serving") || !text.ends_with('\n') {
            assert_eq!(stdout.read(&mut byte).unwrap(), 1, "the server stopped: {text}");
            text.push(byte[0] as char);
        }
        let at = text.find("127.0.0.1:").unwrap() + "127.0.0.1:".len();
        let port = text[at..].split('/').next().unwrap().parse().unwrap();
        Self { child, port }
    }

    fn connect(&self) -> TcpStream {
        let s = TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        s
    }

    /// Sends `request` and returns the whole response (the server closes every connection).
    fn ask(&self, request: &[u8]) -> String {
        let mut s = self.connect();
        let _ = s.write_all(request);
        let mut response = Vec::new();
        let _ = s.read_to_end(&mut response);
        String::from_utf8_lossy(&response).into_owned()
    }

    fn get(&self, path: &str, host: &str) -> String {
        self.ask(format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n\r\n").as_bytes())
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn regression_idle_connections_stalled_view_serve() {
    let (_dir, out) = run_folder("idle");
    let server = Server::start(&out);
    let host = format!("127.0.0.1:{}", server.port);
    let idle: Vec<TcpStream> = (0..10).map(|_| server.connect()).collect();
    let t = Instant::now();
    let page = server.get("/", &host);
    assert!(page.starts_with("HTTP/1.1 200"), "{}", &page[..page.len().min(200)]);
    assert!(t.elapsed() < Duration::from_secs(2), "answered in {:?} beside 10 idle connections", t.elapsed());
    assert!(page.contains("flexsurf-data"));
    // An idle connection is closed with 408 after the head timeout (3 s), not held open.
    let mut first = idle.into_iter().next().unwrap();
    let mut response = String::new();
    let _ = first.read_to_string(&mut response);
    assert!(response.starts_with("HTTP/1.1 408"), "{response}");
}

#[test]
fn regression_view_serve_accepted_an_oversized_request_line() {
    let (_dir, out) = run_folder("oversized");
    let server = Server::start(&out);
    let mut request = b"GET /".to_vec();
    request.extend(std::iter::repeat_n(b'a', 1 << 20));
    let response = server.ask(&request);
    assert!(response.starts_with("HTTP/1.1 431"), "{}", &response[..response.len().min(200)]);
    let host = format!("localhost:{}", server.port);
    assert!(server.get("/state", &host).starts_with("HTTP/1.1 200"), "the server still answers");
}

#[test]
fn regression_view_serve_did_not_check_the_host_header() {
    let (_dir, out) = run_folder("host");
    let server = Server::start(&out);
    let port = server.port;
    for bad in [format!("attacker.example:{port}"), "127.0.0.1".into(), format!("127.0.0.1:{}", port.wrapping_add(1))] {
        let r = server.get("/", &bad);
        assert!(r.starts_with("HTTP/1.1 403"), "{bad}: {r}");
    }
    assert!(server.ask(b"GET / HTTP/1.0\r\n\r\n").starts_with("HTTP/1.1 403"), "no Host at all");
    for good in [format!("127.0.0.1:{port}"), format!("localhost:{port}"), format!("[::1]:{port}")] {
        assert!(server.get("/state", &good).starts_with("HTTP/1.1 200"), "{good}");
    }
    // Traversal still serves no file.
    let host = format!("127.0.0.1:{port}");
    for path in ["/../summary.json", "/summary.json", "/%2e%2e/etc/passwd", "//etc/passwd"] {
        assert!(server.get(path, &host).starts_with("HTTP/1.1 404"), "{path}");
    }
}

#[cfg(unix)]
#[test]
fn regression_view_blocked_forever_on_a_fifo() {
    let (_dir, out) = run_folder("fifo");
    std::fs::remove_file(out.join("summary.json")).unwrap();
    assert!(Command::new("mkfifo").arg(out.join("summary.json")).status().unwrap().success());
    let t = Instant::now();
    let (code, err) = flexsurf(&["view", out.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("summary.json") && err.contains("FIFO"), "{err}");
    assert!(t.elapsed() < Duration::from_secs(20));
}

#[test]
fn regression_two_concurrent_runs_into_one_folder_both_exited_0() {
    let d = scratch("two-runs");
    let scene = drop_scene(&d, 3000);
    let out = d.join("out");
    let args = ["run", scene.to_str().unwrap(), "--out", out.to_str().unwrap()];
    let mut first = Command::new(BIN).args(args).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    // Wait (bounded) until the first run holds the folder: its manifest lists its files.
    let t = Instant::now();
    while !std::fs::read_to_string(out.join("manifest.json")).is_ok_and(|m| m.contains("energy.csv")) {
        assert!(t.elapsed() < Duration::from_secs(60), "the first run did not start");
        std::thread::sleep(Duration::from_millis(20));
    }
    let (code, err) = flexsurf(&[&args[..], &["--overwrite"]].concat());
    let still_running = first.try_wait().unwrap().is_none();
    let _ = first.kill();
    let _ = first.wait();
    if still_running {
        assert_eq!(code, 1, "{err}");
        assert!(err.contains("being written by another flexsurf run"), "{err}");
        assert!(err.contains(&format!("process {}", first.id())), "{err}");
    }
}
