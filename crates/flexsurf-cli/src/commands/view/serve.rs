//! `flexsurf view --serve`: the viewer of a run folder on the loopback interface, following a running
//! simulation. A small server on the standard library's sockets, with the request head parsed by `httparse`
//! (the parser of `hyper`): `tiny_http` was considered and rejected, as it reads a request line of any length,
//! sets no timeouts and spawns a thread for every connection.
//!
//! - It listens on 127.0.0.1 only and answers `GET` of three fixed paths (`/`, `/view.html`, `/state`;
//!   `/favicon.ico` is empty); any other path is 404, so no path reaches a file (no traversal).
//! - A fixed pool of [`WORKERS`] threads answers connections concurrently; each must send its whole request
//!   head within [`HEAD_TIMEOUT`] and in at most [`MAX_HEAD`] bytes (else 408 or 431, and closed after
//!   dropping for at most [`LINGER`] what the client still sends, so that the reply is not lost to a reset),
//!   so idle or oversized connections hold a worker for at most that long and never the server.
//! - The `Host` header must name the loopback address with the server's port (`localhost`, `127.0.0.1` or
//!   `[::1]`), which defeats DNS rebinding (a page of another site resolved to 127.0.0.1 sends its own name).
//! - The page is built once for each state of the run ([`viewer::run_state`]: the sizes and times of
//!   `animation.pvd` and `animation.glb`) and kept: the run folder's files are read again only when the run
//!   wrote to them, not on every request.

use anyhow::{Context, Result};
use flexsurf::runner::viewer;
use std::io::{Read, Write};
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

/// Threads answering connections.
pub const WORKERS: usize = 16;
/// The longest request head read (bytes): the request line and the headers.
pub const MAX_HEAD: usize = 8 * 1024;
/// The time a connection has to send its request head.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(3);
/// The time a response may take to be written.
const WRITE_TIMEOUT: Duration = Duration::from_secs(30);
/// Connections accepted and waiting for a worker, beyond which accepting waits.
const QUEUE: usize = 64;
/// After refusing a request whose head was not read to its end, how long the rest is read and dropped.
const LINGER: Duration = Duration::from_secs(1);
/// ... and how many bytes at most.
const LINGER_BYTES: usize = 4 << 20;

/// The page built for one state of the run (or why it could not be).
type Page = (String, Result<Arc<Vec<u8>>, String>);

/// What the server serves: the run folder, its port, and the page of the run's last state seen.
struct Site {
    dir: PathBuf,
    port: u16,
    page: Mutex<Option<Page>>,
}

/// A parsed request head: method, target, `Host`.
type Head = (String, String, Option<String>);

/// A response: status line, content type, body.
type Reply = (&'static str, &'static str, Arc<Vec<u8>>);

fn text(status: &'static str, body: &str) -> Reply {
    (status, "text/plain; charset=utf-8", Arc::new(body.as_bytes().to_vec()))
}

/// Serves the page of `dir` on 127.0.0.1:`port` until killed.
pub fn serve(dir: &Path, port: u16) -> Result<()> {
    let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, port))
        .with_context(|| format!("--serve: cannot listen on 127.0.0.1:{port}"))?;
    let addr = listener.local_addr()?;
    println!("serving http://{addr}/ (the viewer of {}; Ctrl-C stops)", dir.display());
    std::io::stdout().flush()?;
    let site = Arc::new(Site { dir: dir.to_path_buf(), port: addr.port(), page: Mutex::new(None) });
    let (send, receive) = mpsc::sync_channel::<TcpStream>(QUEUE);
    let receive = Arc::new(Mutex::new(receive));
    for _ in 0..WORKERS {
        let (site, receive) = (Arc::clone(&site), Arc::clone(&receive));
        std::thread::spawn(move || loop {
            // One worker at a time waits on the queue; a poisoned lock (a worker panicked) still hands out.
            let next = receive.lock().unwrap_or_else(std::sync::PoisonError::into_inner).recv();
            let Ok(stream) = next else { return };
            if let Err(e) = answer(&site, stream) {
                eprintln!("--serve: {e:#}");
            }
        });
    }
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        if send.send(stream).is_err() {
            break;
        }
    }
    Ok(())
}

/// The request head of `stream`, read within [`HEAD_TIMEOUT`] and [`MAX_HEAD`] bytes: (method, path, host),
/// or the error reply.
fn read_head(stream: &mut TcpStream) -> std::io::Result<Result<Head, Reply>> {
    let deadline = Instant::now() + HEAD_TIMEOUT;
    let mut buf = vec![0u8; MAX_HEAD];
    let mut len = 0;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Ok(Err(text("408 Request Timeout", "the request head took too long\n")));
        }
        stream.set_read_timeout(Some(left))?;
        let n = match stream.read(&mut buf[len..]) {
            Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            Ok(n) => n,
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => continue,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        len += n;
        let mut headers = [httparse::EMPTY_HEADER; 32];
        let mut request = httparse::Request::new(&mut headers);
        match request.parse(&buf[..len]) {
            Ok(httparse::Status::Complete(_)) => {
                let host = request
                    .headers
                    .iter()
                    .find(|h| h.name.eq_ignore_ascii_case("host"))
                    .map(|h| String::from_utf8_lossy(h.value).trim().to_string());
                let method = request.method.unwrap_or("").to_string();
                return Ok(Ok((method, request.path.unwrap_or("").to_string(), host)));
            }
            Ok(httparse::Status::Partial) if len < MAX_HEAD => {}
            Ok(httparse::Status::Partial) | Err(httparse::Error::TooManyHeaders) => {
                return Ok(Err(text("431 Request Header Fields Too Large", "the request head is too large\n")));
            }
            Err(_) => return Ok(Err(text("400 Bad Request", "not an HTTP request\n"))),
        }
    }
}

/// Whether `host` (a `Host` header) names this server on the loopback interface.
pub fn loopback_host(host: &str, port: u16) -> bool {
    let name = match host.strip_suffix(&format!(":{port}")) {
        Some(name) => name,
        None if port == 80 => host,
        None => return false,
    };
    ["localhost", "127.0.0.1", "[::1]"].iter().any(|n| name.eq_ignore_ascii_case(n))
}

impl Site {
    /// The page of the run as it stands, built only when the run's state changed since the last one.
    fn page(&self) -> Reply {
        let state = viewer::run_state(&self.dir);
        let mut cached = self.page.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if cached.as_ref().is_none_or(|(s, _)| *s != state) {
            let built = viewer::view_html_live(&self.dir, &state).map(|h| Arc::new(h.into_bytes()));
            *cached = Some((state, built.map_err(|e| format!("{e}\n"))));
        }
        match cached.as_ref().map(|(_, page)| page) {
            Some(Ok(page)) => ("200 OK", "text/html; charset=utf-8", Arc::clone(page)),
            Some(Err(e)) => text("503 Service Unavailable", e),
            None => text("503 Service Unavailable", "no page\n"),
        }
    }

    fn reply(&self, method: &str, target: &str, host: Option<&str>) -> Reply {
        if !host.is_some_and(|h| loopback_host(h, self.port)) {
            return text("403 Forbidden", "the Host header must name this server on 127.0.0.1 or localhost\n");
        }
        let path = target.split(['?', '#']).next().unwrap_or("");
        match (method, path) {
            ("GET", "/") | ("GET", "/view.html") => self.page(),
            // Browsers ask for an icon; there is none.
            ("GET", "/favicon.ico") => ("204 No Content", "text/plain; charset=utf-8", Arc::new(Vec::new())),
            ("GET", "/state") => text("200 OK", &viewer::run_state(&self.dir)),
            ("GET", _) => text("404 Not Found", "not found\n"),
            _ => text("405 Method Not Allowed", "only GET\n"),
        }
    }
}

fn answer(site: &Site, mut stream: TcpStream) -> Result<()> {
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    let ((status, kind, body), unread) = match read_head(&mut stream) {
        Ok(Ok((method, target, host))) => (site.reply(&method, &target, host.as_deref()), false),
        Ok(Err(reply)) => (reply, true),
        // The client went away or the connection failed: nothing to answer.
        Err(_) => return Ok(()),
    };
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\
         X-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(&body)?;
    if unread {
        linger(stream);
    }
    Ok(())
}

/// Closes a connection whose client may still be sending: closing a socket with unread input resets it, and
/// the reset can destroy the reply before the client reads it. So the reply is ended (`shutdown(Write)`) and
/// what the client still sends is read and dropped, for at most [`LINGER`] and [`LINGER_BYTES`].
fn linger(mut stream: TcpStream) {
    if stream.shutdown(std::net::Shutdown::Write).is_err() {
        return;
    }
    let deadline = Instant::now() + LINGER;
    let mut sink = [0u8; 16 * 1024];
    let mut total = 0;
    while total < LINGER_BYTES {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() || stream.set_read_timeout(Some(left)).is_err() {
            return;
        }
        match stream.read(&mut sink) {
            Ok(0) => return,
            Ok(n) => total += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => return,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::loopback_host;

    #[test]
    fn only_loopback_names_with_the_port_are_accepted() {
        for ok in ["localhost:8765", "127.0.0.1:8765", "[::1]:8765", "LOCALHOST:8765"] {
            assert!(loopback_host(ok, 8765), "{ok}");
        }
        for bad in ["evil.example:8765", "localhost", "127.0.0.1:80", "localhost.evil:8765", "", "127.0.0.2:8765"] {
            assert!(!loopback_host(bad, 8765), "{bad}");
        }
        assert!(loopback_host("localhost", 80));
    }
}
