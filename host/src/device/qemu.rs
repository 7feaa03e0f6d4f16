//! Running the device image in QEMU (`qemu-system-arm -machine mps2-an386`).
//!
//! Each run gets a private temporary folder (for the UART's Unix socket) and a guard,
//! [`Qemu`], that kills QEMU and removes the folder when dropped: on success, on error and
//! on a panic in the caller. Every run has a deadline, because a hung image (or a QEMU
//! waiting for a UART connection) would otherwise block forever.
//!
//! What the image prints through semihosting arrives on QEMU's stdout and stderr, which
//! are captured. UART0, when asked for, is a Unix socket that QEMU serves with
//! `wait=on`: the guest starts only once the host has connected, so no byte is lost.
//! The image's exit status (semihosting `SYS_EXIT_EXTENDED`) is QEMU's exit status.
//!
//! The HMP monitor, when asked for, is a second Unix socket ([`Qemu::monitor`]): tests
//! stop the machine and save the PARAMS region (`pmemsave`) to simulate a power cut.

use std::ffi::OsString;
use std::io::{self, Read};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStderr, ChildStdout, Command, ExitStatus, Stdio};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use crate::device::scratch::ScratchDir;

/// The QEMU binary: `$SUPINE_QEMU` if set, else `qemu-system-arm` on the `PATH`.
pub const QEMU_ENV: &str = "SUPINE_QEMU";
/// The QEMU program run when [`QEMU_ENV`] is not set.
pub const QEMU_PROGRAM: &str = "qemu-system-arm";
/// The emulated board: Cortex-M4 with FPU.
pub const MACHINE: &str = "mps2-an386";
/// Where the parameter blob is loaded: the PARAMS region of `memory.x`.
pub const PARAMS_ADDR: u32 = crate::device::memory_map::PARAMS_ORIGIN;
/// Largest parameter blob: the PARAMS region's size.
pub const PARAMS_MAX_BYTES: u64 = crate::device::memory_map::PARAMS_LENGTH_BYTES as u64;

/// How often a waiting run checks on QEMU.
const POLL: Duration = Duration::from_millis(5);
/// Longest a run waits for QEMU to open its UART (or monitor) socket, which it does at
/// start-up, well within a second: a program that never opens it (a `SUPINE_QEMU` that
/// is not a QEMU, or one that hangs) is given up on after this, whatever the run's own
/// deadline (the README's "Environment" gives the same figure).
pub const SOCKET_OPEN_TIMEOUT: Duration = Duration::from_secs(20);

/// How to run an image.
#[derive(Debug, Clone)]
pub struct QemuConfig {
    /// The ELF file to run.
    pub kernel: PathBuf,
    /// Count instructions (`-icount shift=0,align=off,sleep=off`): one instruction per
    /// nanosecond of virtual time, so SysTick measures instructions, reproducibly.
    pub icount: bool,
    /// A parameter blob to load at [`PARAMS_ADDR`].
    pub params_blob: Option<PathBuf>,
    /// Connect UART0 to a Unix socket (see [`Qemu::uart`]); otherwise UART0 goes nowhere.
    pub uart: bool,
    /// Serve the HMP monitor on a Unix socket (see [`Qemu::monitor`]); otherwise none.
    pub monitor: bool,
    /// The image's command line, as semihosting `SYS_GET_CMDLINE` returns it (words).
    pub semihosting_args: Vec<String>,
    /// Longest the run may take, from the start of QEMU to its exit.
    pub timeout: Duration,
}

impl QemuConfig {
    /// A run of `kernel` without instruction counting, blob or UART, and a 60 s deadline.
    pub fn new(kernel: impl Into<PathBuf>) -> Self {
        Self {
            kernel: kernel.into(),
            icount: false,
            params_blob: None,
            uart: false,
            monitor: false,
            semihosting_args: Vec::new(),
            timeout: Duration::from_secs(60),
        }
    }

    /// Turns instruction counting on.
    pub fn icount(mut self) -> Self {
        self.icount = true;
        self
    }

    /// Loads `blob` at [`PARAMS_ADDR`].
    pub fn params_blob(mut self, blob: impl Into<PathBuf>) -> Self {
        self.params_blob = Some(blob.into());
        self
    }

    /// Connects UART0 to the host.
    pub fn uart(mut self) -> Self {
        self.uart = true;
        self
    }

    /// Serves the HMP monitor to the host.
    pub fn monitor(mut self) -> Self {
        self.monitor = true;
        self
    }

    /// Appends a word to the image's semihosting command line.
    pub fn semihosting_arg(mut self, arg: impl Into<String>) -> Self {
        self.semihosting_args.push(arg.into());
        self
    }

    /// Sets the deadline.
    pub fn timeout(mut self, timeout: Duration) -> Self {
        self.timeout = timeout;
        self
    }
}

/// How a finished run ended and what it printed.
#[derive(Debug, Clone)]
pub struct QemuOutput {
    /// QEMU's exit status: the image's semihosting exit status.
    pub status: ExitStatus,
    /// What the image printed to semihosting stdout (and QEMU's own messages).
    pub stdout: String,
    /// What the image printed to semihosting stderr (panic messages) and QEMU's errors.
    pub stderr: String,
}

impl QemuOutput {
    /// The exit code, `None` if QEMU was killed by a signal.
    pub fn code(&self) -> Option<i32> {
        self.status.code()
    }
}

/// Why a run failed to produce an exit status.
#[derive(Debug, thiserror::Error)]
pub enum QemuError {
    /// QEMU could not be started.
    #[error(
        "cannot run {program} ({source}): run `bash .ci/setup` or install Debian's qemu-system-arm"
    )]
    Missing {
        /// The program tried.
        program: String,
        /// Why it did not start.
        source: io::Error,
    },
    /// The kernel or the parameter blob is not a readable file, or the blob is too large.
    #[error("{0}")]
    BadInput(String),
    /// The temporary folder or a pipe could not be made.
    #[error("cannot prepare the QEMU run: {0}")]
    Io(#[from] io::Error),
    /// QEMU exited before its UART socket could be connected.
    #[error("QEMU exited with {status} before the UART was connected: {stderr}")]
    ExitedEarly {
        /// Its exit status.
        status: ExitStatus,
        /// Its stderr on one line.
        stderr: String,
    },
    /// The program did not open its socket within [`SOCKET_OPEN_TIMEOUT`]; it was killed.
    #[error(
        "{program} did not open its UART socket within {} (QEMU does at start-up) and was stopped: expected {QEMU_ENV} to name a qemu-system-arm",
        crate::device::link::format_duration(SOCKET_OPEN_TIMEOUT)
    )]
    NoSocket {
        /// The program run.
        program: String,
    },
    /// The deadline passed; QEMU was killed.
    #[error("QEMU did not finish within {} and was killed; last output: {}", crate::device::link::format_duration(*timeout), last_line(stdout))]
    Timeout {
        /// The deadline.
        timeout: Duration,
        /// What it printed to stdout before it was killed.
        stdout: String,
        /// What it printed to stderr before it was killed.
        stderr: String,
    },
}

/// A running QEMU. Dropping it kills QEMU and removes its temporary folder.
#[derive(Debug)]
pub struct Qemu {
    child: Child,
    uart: Option<UnixStream>,
    monitor: Option<UnixStream>,
    stdout: Option<JoinHandle<String>>,
    stderr: Option<JoinHandle<String>>,
    deadline: Instant,
    timeout: Duration,
    /// The program run (for messages).
    program: String,
    /// When it was started.
    started: Instant,
    // Dropped after `Drop::drop` has killed QEMU, so the socket goes with the folder.
    dir: ScratchDir,
}

impl Qemu {
    /// Starts QEMU on `config`; with a UART, returns once the host side is connected.
    pub fn start(config: &QemuConfig) -> Result<Self, QemuError> {
        check_inputs(config)?;
        let dir = ScratchDir::new("qemu")?;
        let socket = dir.path().join("uart.sock");
        let program = qemu_program();
        let mut command = Command::new(&program);
        die_with_this_thread(&mut command);
        let mut child = command
            .args(arguments(config, &socket))
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|source| QemuError::Missing {
                program: program.to_string_lossy().into_owned(),
                source,
            })?;
        let started = Instant::now();
        let deadline = started + config.timeout;
        let stdout = child.stdout.take().map(collect_stdout);
        let stderr = child.stderr.take().map(collect_stderr);
        let mut qemu = Self {
            child,
            uart: None,
            monitor: None,
            stdout,
            stderr,
            deadline,
            timeout: config.timeout,
            program: program.to_string_lossy().into_owned(),
            started,
            dir,
        };
        if config.uart {
            qemu.uart = Some(qemu.connect_socket(&socket)?);
        }
        if config.monitor {
            let path = monitor_socket(qemu.dir.path());
            let monitor = qemu.connect_socket(&path)?;
            monitor.set_read_timeout(Some(POLL))?;
            // The banner ends with the first prompt.
            qemu.monitor = Some(monitor);
            qemu.read_monitor_reply()?;
        }
        Ok(qemu)
    }

    /// Runs an HMP monitor command (e.g. `stop`, `pmemsave <PARAMS_ADDR> 65536 FILE`) and
    /// returns what QEMU answered; it has completed when this returns.
    pub fn monitor(&mut self, command: &str) -> Result<String, QemuError> {
        use std::io::Write;
        let monitor = self.monitor.as_mut().ok_or_else(|| {
            QemuError::BadInput("this QEMU run has no monitor: use QemuConfig::monitor".into())
        })?;
        monitor.write_all(command.as_bytes())?;
        monitor.write_all(b"\n")?;
        self.read_monitor_reply()
    }

    /// Saves `len_bytes` of guest memory from `addr` to the file `out` (`pmemsave`).
    pub fn save_memory(
        &mut self,
        addr: u32,
        len_bytes: usize,
        out: &Path,
    ) -> Result<(), QemuError> {
        // HMP parses the size as an expression, so a path starting with `/` would read as
        // a division: name the file relative to the working directory QEMU shares with us.
        let out = std::path::absolute(out)?;
        let cwd = std::env::current_dir()?;
        let mut relative = PathBuf::from(".");
        relative.extend(cwd.components().skip(1).map(|_| ".."));
        relative.extend(out.components().skip(1));
        let reply = self.monitor(&format!(
            "pmemsave {addr:#x} {len_bytes} {}",
            relative.display()
        ))?;
        let written = std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0);
        if written != len_bytes as u64 {
            return Err(QemuError::BadInput(format!(
                "pmemsave to {} failed: {}",
                out.display(),
                one_line(&reply)
            )));
        }
        Ok(())
    }

    /// Reads the monitor's output up to its next prompt.
    fn read_monitor_reply(&mut self) -> Result<String, QemuError> {
        const PROMPT: &str = "(qemu) ";
        let mut text = Vec::new();
        let mut buf = [0u8; 1024];
        loop {
            let Some(monitor) = self.monitor.as_mut() else {
                return Err(QemuError::BadInput("no monitor".into()));
            };
            match monitor.read(&mut buf) {
                Ok(0) => {
                    return Err(QemuError::Io(io::Error::new(
                        io::ErrorKind::UnexpectedEof,
                        "the QEMU monitor closed",
                    )));
                }
                Ok(n) => text.extend_from_slice(&buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) => {}
                Err(e) => return Err(e.into()),
            }
            let reply = String::from_utf8_lossy(&text);
            if let Some(body) = reply.strip_suffix(PROMPT) {
                return Ok(body.to_owned());
            }
            if Instant::now() >= self.deadline {
                return Err(self.kill_for_timeout());
            }
        }
    }

    /// The host end of UART0 (present when the config asked for a UART).
    pub fn uart(&mut self) -> Option<&mut UnixStream> {
        self.uart.as_mut()
    }

    /// QEMU's exit status if it has exited on its own, waiting up to `grace` for it (a
    /// link that just failed may be QEMU dying).
    pub fn exited_within(&mut self, grace: Duration) -> Option<ExitStatus> {
        let until = Instant::now() + grace;
        loop {
            match self.child.try_wait() {
                Ok(Some(status)) => return Some(status),
                Ok(None) if Instant::now() < until => thread::sleep(POLL),
                _ => return None,
            }
        }
    }

    /// Adds to a failed run's error that QEMU itself had exited, and how, if it had.
    pub fn explain_failure(&mut self, err: anyhow::Error) -> anyhow::Error {
        match self.exited_within(Duration::from_millis(200)) {
            Some(status) => err.context(format!("QEMU exited during the run ({status})")),
            None => err,
        }
    }

    /// QEMU's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// The temporary folder of this run (removed when the guard is dropped).
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Time left before the deadline.
    pub fn remaining(&self) -> Duration {
        self.deadline.saturating_duration_since(Instant::now())
    }

    /// Waits for QEMU to exit (the image ended its run) until the deadline.
    pub fn wait(mut self) -> Result<QemuOutput, QemuError> {
        loop {
            if let Some(status) = self.child.try_wait()? {
                return Ok(self.output(status));
            }
            if Instant::now() >= self.deadline {
                return Err(self.kill_for_timeout());
            }
            thread::sleep(POLL);
        }
    }

    /// Kills QEMU now (for images that never exit) and returns what it printed.
    pub fn stop(mut self) -> Result<QemuOutput, QemuError> {
        self.kill()
    }

    /// Kills QEMU past its deadline; the error carries what it printed.
    fn kill_for_timeout(&mut self) -> QemuError {
        match self.kill() {
            Ok(output) => QemuError::Timeout {
                timeout: self.timeout,
                stdout: output.stdout,
                stderr: output.stderr,
            },
            Err(e) => e,
        }
    }

    fn kill(&mut self) -> Result<QemuOutput, QemuError> {
        // Closing our end first lets QEMU see EOF rather than a reset mid-write.
        self.uart = None;
        self.monitor = None;
        if self.child.try_wait()?.is_none() {
            // It may exit between the check and the kill; then kill's error is harmless.
            let _ = self.child.kill();
        }
        let status = self.child.wait()?;
        Ok(self.output(status))
    }

    fn output(&mut self, status: ExitStatus) -> QemuOutput {
        QemuOutput {
            status,
            stdout: join(self.stdout.take()),
            stderr: join(self.stderr.take()),
        }
    }

    /// Connects to a socket QEMU serves, retrying until it appears or QEMU gives up.
    fn connect_socket(&mut self, socket: &Path) -> Result<UnixStream, QemuError> {
        loop {
            match UnixStream::connect(socket) {
                Ok(stream) => return Ok(stream),
                Err(err)
                    if matches!(
                        err.kind(),
                        io::ErrorKind::NotFound | io::ErrorKind::ConnectionRefused
                    ) => {}
                Err(err) => return Err(err.into()),
            }
            if let Some(status) = self.child.try_wait()? {
                let stderr = join(self.stderr.take());
                return Err(QemuError::ExitedEarly {
                    status,
                    stderr: one_line(&stderr),
                });
            }
            if Instant::now() >= self.deadline {
                return Err(self.kill_for_timeout());
            }
            if self.started.elapsed() >= SOCKET_OPEN_TIMEOUT {
                let _ = self.kill();
                return Err(QemuError::NoSocket {
                    program: self.program.clone(),
                });
            }
            thread::sleep(POLL);
        }
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        self.uart = None;
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        // Reap it so no zombie is left; the pipes' reader threads end with it.
        let _ = self.child.wait();
    }
}

/// Makes the kernel kill the child (SIGKILL) when the thread that spawns it ends, so QEMU
/// cannot outlive `supine` however `supine` dies (`kill -9`, an out-of-memory kill), when
/// no destructor runs. The signal follows the spawning *thread*: a [`Qemu`] is started and
/// dropped on one thread, which is how every caller uses it.
fn die_with_this_thread(command: &mut Command) {
    use std::os::unix::process::CommandExt;
    let parent = nix::unistd::getpid();
    // SAFETY: the closure runs in the forked child before exec and calls only prctl(2),
    // getppid(2) and returns: async-signal-safe system calls, no allocation, no locks.
    unsafe {
        command.pre_exec(move || {
            nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGKILL)
                .map_err(io::Error::from)?;
            // The parent may have died before the prctl took effect: then exit now.
            if nix::unistd::getppid() != parent {
                return Err(io::Error::other("supine ended before QEMU started"));
            }
            Ok(())
        });
    }
}

/// Runs `config` to completion: start, wait, clean up.
pub fn run(config: &QemuConfig) -> Result<QemuOutput, QemuError> {
    Qemu::start(config)?.wait()
}

/// QEMU's command line for `config`, with UART0 on `socket` if asked.
pub fn arguments(config: &QemuConfig, socket: &Path) -> Vec<OsString> {
    let mut args: Vec<OsString> = Vec::new();
    let mut push = |arg: &str| args.push(OsString::from(arg));
    push("-machine");
    push(MACHINE);
    push("-nographic");
    // With -nographic a default monitor would share stdout with the image's output.
    push("-monitor");
    if config.monitor {
        let path = monitor_socket(socket.parent().unwrap_or(Path::new(".")));
        args.push(option_with_path("unix:", &path, ",server=on,wait=off"));
    } else {
        push("none");
    }
    let mut push = |arg: &str| args.push(OsString::from(arg));
    push("-semihosting-config");
    let mut semihosting = String::from("enable=on,target=native");
    for arg in &config.semihosting_args {
        semihosting.push_str(",arg=");
        semihosting.push_str(&arg.replace(',', ",,"));
    }
    push(&semihosting);
    if config.icount {
        push("-icount");
        push("shift=0,align=off,sleep=off");
    }
    if let Some(blob) = &config.params_blob {
        push("-device");
        args.push(option_with_path(
            "loader,file=",
            blob,
            &format!(",addr={PARAMS_ADDR:#x}"),
        ));
    }
    let mut push = |arg: &str| args.push(OsString::from(arg));
    if config.uart {
        push("-chardev");
        args.push(option_with_path(
            "socket,id=u0,path=",
            socket,
            ",server=on,wait=on",
        ));
        args.push(OsString::from("-serial"));
        args.push(OsString::from("chardev:u0"));
    } else {
        push("-serial");
        push("null");
    }
    args.push(OsString::from("-kernel"));
    args.push(config.kernel.clone().into_os_string());
    args
}

/// The monitor's socket in a run's folder (next to the UART's).
fn monitor_socket(dir: &Path) -> PathBuf {
    dir.join("monitor.sock")
}

/// `prefix` + `path` + `suffix`, with commas in the path doubled as QEMU's option syntax
/// requires.
fn option_with_path(prefix: &str, path: &Path, suffix: &str) -> OsString {
    let escaped = path.to_string_lossy().replace(',', ",,");
    OsString::from(format!("{prefix}{escaped}{suffix}"))
}

fn check_inputs(config: &QemuConfig) -> Result<(), QemuError> {
    if !config.kernel.is_file() {
        return Err(QemuError::BadInput(format!(
            "no firmware image at {}",
            config.kernel.display()
        )));
    }
    if let Some(blob) = &config.params_blob {
        let len = std::fs::metadata(blob)
            .map_err(|err| {
                QemuError::BadInput(format!(
                    "cannot read parameter blob {}: {err}",
                    blob.display()
                ))
            })?
            .len();
        if len > PARAMS_MAX_BYTES {
            return Err(QemuError::BadInput(format!(
                "parameter blob {} has {len} bytes; the PARAMS region holds {PARAMS_MAX_BYTES}",
                blob.display()
            )));
        }
    }
    Ok(())
}

fn qemu_program() -> OsString {
    std::env::var_os(QEMU_ENV)
        .filter(|program| !program.is_empty())
        .unwrap_or_else(|| OsString::from(QEMU_PROGRAM))
}

fn collect_stdout(pipe: ChildStdout) -> JoinHandle<String> {
    thread::spawn(move || read_lossy(pipe))
}

fn collect_stderr(pipe: ChildStderr) -> JoinHandle<String> {
    thread::spawn(move || read_lossy(pipe))
}

/// Reads a pipe to its end; a read error ends the text where it happened.
fn read_lossy(mut pipe: impl Read) -> String {
    let mut bytes = Vec::new();
    let _ = pipe.read_to_end(&mut bytes);
    String::from_utf8_lossy(&bytes).into_owned()
}

fn join(handle: Option<JoinHandle<String>>) -> String {
    handle
        .and_then(|handle| handle.join().ok())
        .unwrap_or_default()
}

fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn last_line(text: &str) -> &str {
    text.lines()
        .rev()
        .find(|line| !line.trim().is_empty())
        .unwrap_or("(none)")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args_of(config: &QemuConfig) -> Vec<String> {
        arguments(config, Path::new("/tmp/x/uart.sock"))
            .into_iter()
            .map(|arg| arg.to_string_lossy().into_owned())
            .collect()
    }

    #[test]
    fn a_plain_run_has_semihosting_no_monitor_and_no_uart() {
        let args = args_of(&QemuConfig::new("/fw/selftest"));
        let line = args.join(" ");
        assert!(line.contains("-machine mps2-an386"), "{line}");
        assert!(
            line.contains("-semihosting-config enable=on,target=native"),
            "{line}"
        );
        assert!(line.contains("-monitor none"), "{line}");
        assert!(line.contains("-serial null"), "{line}");
        assert!(!line.contains("-icount"), "{line}");
        assert!(line.ends_with("-kernel /fw/selftest"), "{line}");
    }

    #[test]
    fn icount_blob_and_uart_add_their_options() {
        let config = QemuConfig::new("/fw/img")
            .icount()
            .params_blob("/data/a,b.bin")
            .uart();
        let line = args_of(&config).join(" ");
        assert!(
            line.contains("-icount shift=0,align=off,sleep=off"),
            "{line}"
        );
        // The comma in the blob's path is doubled, QEMU's escape.
        assert!(
            line.contains(&format!(
                "-device loader,file=/data/a,,b.bin,addr={PARAMS_ADDR:#x}"
            )),
            "{line}"
        );
        assert!(
            line.contains(
                "-chardev socket,id=u0,path=/tmp/x/uart.sock,server=on,wait=on -serial chardev:u0"
            ),
            "{line}"
        );
    }

    #[test]
    fn semihosting_arguments_follow_the_semihosting_options() {
        let config = QemuConfig::new("/fw/img")
            .semihosting_arg("power_cut")
            .semihosting_arg("1,2");
        let line = args_of(&config).join(" ");
        assert!(
            line.contains("-semihosting-config enable=on,target=native,arg=power_cut,arg=1,,2"),
            "{line}"
        );
    }

    #[test]
    fn a_monitor_is_served_on_a_socket_beside_the_uart() {
        let line = args_of(&QemuConfig::new("/fw/img").uart().monitor()).join(" ");
        assert!(
            line.contains("-monitor unix:/tmp/x/monitor.sock,server=on,wait=off"),
            "{line}"
        );
        assert!(!line.contains("-monitor none"), "{line}");
    }

    #[test]
    fn a_missing_kernel_is_refused_before_qemu_starts() {
        let err = run(&QemuConfig::new("/nonexistent/selftest")).expect_err("no kernel");
        assert!(matches!(err, QemuError::BadInput(_)));
        assert!(err.to_string().contains("/nonexistent/selftest"));
    }

    #[test]
    fn a_blob_larger_than_the_params_region_is_refused() {
        let dir = tempfile::tempdir().expect("temp dir");
        let kernel = dir.path().join("kernel.elf");
        let blob = dir.path().join("params.bin");
        std::fs::write(&kernel, b"not run").expect("write kernel");
        std::fs::write(&blob, vec![0u8; PARAMS_MAX_BYTES as usize + 1]).expect("write blob");
        let err = run(&QemuConfig::new(&kernel).params_blob(&blob)).expect_err("too large");
        assert!(err.to_string().contains("PARAMS region"), "{err}");
    }
}
