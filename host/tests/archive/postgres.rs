//! A private PostgreSQL server for this test binary, as the QEMU tests run their own QEMU:
//! its own data folder under a temporary folder and its own port, started on first use and
//! stopped when the test process ends (a watcher process stops it and removes the folder,
//! whether the tests pass, fail or are killed).
//!
//! `initdb` and `postgres` refuse to run as root: as root, they run as the `postgres` user
//! (Debian's package creates it), which is given the folder.

use std::net::TcpListener;
use std::os::unix::fs::PermissionsExt as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

struct Server {
    bin: PathBuf,
    port: u16,
}

static SERVER: OnceLock<Server> = OnceLock::new();
static DATABASES: AtomicUsize = AtomicUsize::new(0);

/// The newest `/usr/lib/postgresql/*/bin` with `initdb`.
fn bin_dir() -> PathBuf {
    let mut found: Vec<(u32, PathBuf)> = std::fs::read_dir("/usr/lib/postgresql")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let v = e.file_name().to_str()?.parse::<u32>().ok()?;
            let bin = e.path().join("bin");
            bin.join("initdb").exists().then_some((v, bin))
        })
        .collect();
    found.sort();
    found
        .pop()
        .map(|(_, b)| b)
        .expect("PostgreSQL is not installed (no /usr/lib/postgresql/*/bin/initdb): run .ci/setup")
}

fn is_root() -> bool {
    use std::os::unix::fs::MetadataExt as _;
    std::fs::metadata("/proc/self").is_ok_and(|m| m.uid() == 0)
}

/// `program args...`, as the `postgres` user when this process is root.
fn as_server_user(program: &Path) -> Command {
    if is_root() {
        let mut c = Command::new("runuser");
        c.args(["-u", "postgres", "--"]).arg(program);
        c
    } else {
        Command::new(program)
    }
}

fn run(mut c: Command, what: &str) {
    let out = c.output().unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn start() -> Server {
    let bin = bin_dir();
    let dir = tempfile::Builder::new()
        .prefix("supine-pg-")
        .tempdir()
        .expect("a temporary folder")
        .keep();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).unwrap();
    if is_root() {
        run(
            {
                let mut c = Command::new("chown");
                c.arg("postgres:").arg(&dir);
                c
            },
            "chown",
        );
    }
    let data = dir.join("data");
    let mut init = as_server_user(&bin.join("initdb"));
    init.args([
        "--auth=trust",
        "--username=postgres",
        "--encoding=UTF8",
        "--no-sync",
        "-D",
    ])
    .arg(&data);
    run(init, "initdb");
    let port = TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port");
    let mut ctl = as_server_user(&bin.join("pg_ctl"));
    ctl.arg("-D").arg(&data).arg("-l").arg(dir.join("server.log")).args([
        "-w",
        "-o",
        &format!(
            "-p {port} -k {} -c listen_addresses=127.0.0.1 -c fsync=off -c full_page_writes=off",
            dir.display()
        ),
        "start",
    ]);
    ctl.stdout(Stdio::null());
    run(ctl, "pg_ctl start");
    // The watcher (it may not signal this process, so it watches /proc): when this test
    // process is gone, stop the server and remove its folder.
    let script = format!(
        "while [ -d /proc/{pid} ]; do sleep 1; done; \
         '{ctl}' -D '{data}' -m immediate stop >/dev/null 2>&1; rm -rf '{dir}'",
        pid = std::process::id(),
        ctl = bin.join("pg_ctl").display(),
        data = data.display(),
        dir = dir.display()
    );
    // In a session of its own (setsid), so that a signal to this test's process group
    // (Ctrl-C, a timeout) does not take the watcher with it; `-f` forks it off, so the
    // setsid this process waits for returns at once.
    let mut watcher = Command::new("setsid");
    watcher
        .arg("-f")
        .arg(if is_root() { "runuser" } else { "sh" });
    if is_root() {
        watcher.args(["-u", "postgres", "--", "/bin/sh"]);
    }
    watcher
        .args(["-c", &script])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    let started = watcher.status().expect("the server's watcher");
    assert!(started.success(), "the server's watcher did not start");
    Server { bin, port }
}

/// A new, empty database on this binary's server, as a `postgres://` URL.
pub fn database() -> String {
    let server = SERVER.get_or_init(start);
    let name = format!(
        "supine_{}_{}",
        std::process::id(),
        DATABASES.fetch_add(1, Ordering::SeqCst)
    );
    let mut c = Command::new(server.bin.join("createdb"));
    c.args([
        "-h",
        "127.0.0.1",
        "-p",
        &server.port.to_string(),
        "-U",
        "postgres",
        &name,
    ]);
    run(c, "createdb");
    format!("postgres://postgres@127.0.0.1:{}/{name}", server.port)
}
