//! The hostile-input suite for the files the host reads (issue 17): every reader, through
//! the `supine` command a user runs, fed files an attacker or an accident would give it.
//!
//! Each malformed file must be refused with a non-zero exit and exactly one line on
//! stderr, at most [`MAX_ERROR_CHARS`] characters, naming the file (and the line and field
//! where there is one), without a panic and within [`MAX_RSS_KB`] of memory, however large
//! the file (2 GiB sparse files of NUL bytes cost no disk). A valid file with a UTF-8 byte
//! order mark or CRLF line ends must be accepted: editors on Windows write both.
//!
//! Memory is the child's peak resident set (`VmHWM` in `/proc/PID/status`), polled while
//! it runs (a child over the limit is killed there, so a regression cannot exhaust the
//! machine), and, exactly, the largest child's `ru_maxrss` after all have been reaped.
//! Run with `--nocapture` for the table of cases (BENCHMARKS.md, "Verification").

use std::ffi::OsString;
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use supine_host::identify::synth::{SynthSettings, write_dataset};
use supine_host::io::params_file::{self, ParamFile};
use supine_host::io::recording::{HEADER_LINE, PLATFORM_HEADER_LINE};

/// Longest error line accepted, characters (files are named relative to the working
/// folder, as a user names them).
const MAX_ERROR_CHARS: usize = 200;
/// Largest peak resident set of one `supine` run, KiB: a few times what the valid inputs
/// here take, and a hundredth of what reading a 2 GiB file whole costs.
const MAX_RSS_KB: u64 = 200 * 1024;
/// The size of the huge files (sparse: no disk space).
const HUGE_BYTES: u64 = 2 << 30;
/// A field far longer than any real one.
const HUGE_FIELD_BYTES: usize = 1_000_000;
/// Longest one case may run.
const CASE_TIMEOUT: Duration = Duration::from_secs(120);

/// What a case must do.
enum Expect {
    /// Refused: the error line names the hostile file and contains each of these.
    Refused(Vec<String>),
    /// Accepted: exit 0.
    Accepted,
    /// The file is accepted; the command then fails for the reason given here (a serial
    /// port that does not exist), which must be what the error line names.
    AcceptedThenFailsOn(String),
}

struct Case {
    name: String,
    /// Where `supine` runs: file arguments are relative to it, as a user gives them.
    cwd: PathBuf,
    /// The hostile file (its name must appear in a refusal).
    file: PathBuf,
    args: Vec<OsString>,
    env: Vec<(String, PathBuf)>,
    expect: Expect,
}

struct Outcome {
    code: Option<i32>,
    /// The first 64 KiB of stderr (the rest is only counted).
    stderr: String,
    stderr_bytes: usize,
    peak_rss_kb: u64,
    killed_for: Option<String>,
}

fn peak_rss_kb(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn run(case: &Case) -> Outcome {
    let mut command = Command::new(env!("CARGO_BIN_EXE_supine"));
    command
        .args(&case.args)
        .current_dir(&case.cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    for (key, value) in &case.env {
        command.env(key, value);
    }
    let mut child = command.spawn().expect("supine starts");
    let mut stderr = child.stderr.take().expect("stderr");
    // A reader thread keeps the head of stderr and counts the rest: a regression that
    // prints a 2 GiB line must not cost the test that memory.
    let reader = std::thread::spawn(move || {
        let (mut head, mut total, mut buf) = (Vec::new(), 0usize, vec![0u8; 1 << 16]);
        while let Ok(n) = stderr.read(&mut buf) {
            if n == 0 {
                break;
            }
            total += n;
            let room = (1usize << 16).saturating_sub(head.len());
            head.extend_from_slice(&buf[..n.min(room)]);
        }
        (head, total)
    });
    let started = Instant::now();
    let (mut peak, mut killed_for) = (0, None);
    let status = loop {
        if let Some(kb) = peak_rss_kb(child.id()) {
            peak = peak.max(kb);
        }
        if let Some(status) = child.try_wait().expect("wait") {
            break status;
        }
        if killed_for.is_none() && peak > MAX_RSS_KB {
            killed_for = Some(format!("peak RSS {peak} KiB over {MAX_RSS_KB} KiB"));
            let _ = child.kill();
        } else if killed_for.is_none() && started.elapsed() > CASE_TIMEOUT {
            killed_for = Some(format!("still running after {CASE_TIMEOUT:?}"));
            let _ = child.kill();
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let (head, total) = reader.join().expect("stderr reader");
    Outcome {
        code: status.code(),
        stderr: String::from_utf8_lossy(&head).into_owned(),
        stderr_bytes: total,
        peak_rss_kb: peak,
        killed_for,
    }
}

/// Whether `outcome` is what `case` must do; the reason if not.
fn judge(case: &Case, outcome: &Outcome) -> Result<(), String> {
    if let Some(why) = &outcome.killed_for {
        return Err(why.clone());
    }
    if outcome.peak_rss_kb > MAX_RSS_KB {
        return Err(format!("peak RSS {} KiB", outcome.peak_rss_kb));
    }
    let err = &outcome.stderr;
    if err.contains("panicked") || outcome.code == Some(101) {
        return Err(format!("panic: {}", first_chars(err, 300)));
    }
    let one_line = |err: &str| -> Result<(), String> {
        let line = err.strip_suffix('\n').unwrap_or(err);
        if outcome.stderr_bytes != err.len() || line.contains('\n') || !err.ends_with('\n') {
            return Err(format!(
                "not one line: {} bytes on stderr: {}",
                outcome.stderr_bytes,
                first_chars(err, 200)
            ));
        }
        if let Some(c) = line.chars().find(|c| c.is_control()) {
            return Err(format!(
                "an unescaped control character {c:?}: {}",
                first_chars(line, 200).escape_debug()
            ));
        }
        if line.chars().count() > MAX_ERROR_CHARS {
            return Err(format!(
                "a line of {} characters: {}",
                line.chars().count(),
                first_chars(line, 200)
            ));
        }
        Ok(())
    };
    match &case.expect {
        Expect::Accepted if outcome.code == Some(0) => Ok(()),
        Expect::Accepted => Err(format!(
            "refused ({:?}): {}",
            outcome.code,
            first_chars(err, 300)
        )),
        Expect::AcceptedThenFailsOn(reason) => {
            one_line(err)?;
            let file = file_name(&case.file);
            if err.contains(reason.as_str()) && !err.contains(&file) {
                Ok(())
            } else {
                Err(format!("expected a failure on {reason}, got: {err}"))
            }
        }
        Expect::Refused(needles) => {
            if outcome.code == Some(0) || outcome.code.is_none() {
                return Err(format!("accepted ({:?}): {}", outcome.code, err));
            }
            one_line(err)?;
            let file = file_name(&case.file);
            if !err.contains(&file) {
                return Err(format!("the error does not name {file}: {err}"));
            }
            match needles.iter().find(|n| !err.contains(n.as_str())) {
                Some(missing) => Err(format!("the error does not say {missing:?}: {err}")),
                None => Ok(()),
            }
        }
    }
}

fn first_chars(text: &str, n: usize) -> String {
    text.chars().take(n).collect()
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .expect("a file name")
        .to_string_lossy()
        .into_owned()
}

/// Held by every test that starts children: `RUSAGE_CHILDREN` is the whole test binary's,
/// so the suites run one at a time and each reads the peak of its own children only.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Runs every case, prints one line each and the count, and fails listing what broke.
fn run_suite(category: &str, cases: &[Case]) {
    let _one_at_a_time = one_at_a_time();
    let mut broken = Vec::new();
    for case in cases {
        let outcome = run(case);
        let verdict = judge(case, &outcome);
        println!(
            "{category} | {} | {} | polled peak {} KiB | {}",
            case.name,
            if verdict.is_ok() { "held" } else { "BROKE" },
            outcome.peak_rss_kb,
            first_chars(outcome.stderr.trim_end(), 160)
        );
        if let Err(why) = verdict {
            broken.push(format!("{}: {why}", case.name));
        }
    }
    // Exact, unlike polling: the largest resident set of any child reaped so far (every
    // child of this test binary is bound by the same limit).
    let children = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN)
        .expect("getrusage");
    let max_rss_kb = children.max_rss() as u64;
    println!(
        "{category}: tried {}, held {}; largest child so far {max_rss_kb} KiB",
        cases.len(),
        cases.len() - broken.len()
    );
    // A child starts as a copy of this test binary (its pages count in the child's resident
    // set until it execs supine), so the bound is the limit above this binary's own peak:
    // other tests running beside this one can raise that peak.
    let own_peak_kb = peak_rss_kb(std::process::id()).unwrap_or(0);
    if max_rss_kb > MAX_RSS_KB + own_peak_kb {
        broken.push(format!(
            "a child's peak RSS was {max_rss_kb} KiB (this test binary's own: {own_peak_kb} KiB)"
        ));
    }
    assert!(broken.is_empty(), "{category}:\n{}", broken.join("\n"));
}

/// A path in a test's temporary folder as seen from that folder (where `supine` runs).
fn rel(path: &Path) -> PathBuf {
    path.file_name()
        .map_or_else(|| path.to_path_buf(), PathBuf::from)
}

fn os(items: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<OsString> {
    items.iter().map(|s| s.as_ref().to_os_string()).collect()
}

fn garbage(len: usize, seed: u64) -> Vec<u8> {
    let mut bytes = vec![0u8; len];
    ChaCha8Rng::seed_from_u64(seed).fill_bytes(&mut bytes);
    bytes
}

/// `prefix` followed by NUL bytes up to `len` bytes, as a sparse file.
fn sparse(path: &Path, prefix: &[u8], len: u64) {
    std::fs::write(path, prefix).expect("write");
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .expect("open");
    file.set_len(len).expect("set_len");
}

fn with_bom(text: &str) -> Vec<u8> {
    let mut bytes = b"\xef\xbb\xbf".to_vec();
    bytes.extend_from_slice(text.as_bytes());
    bytes
}

fn crlf(text: &str) -> String {
    text.replace('\n', "\r\n")
}

/// A valid ride of 10 s at 500 Hz, written by `supine ride`.
fn valid_ride(dir: &Path) -> String {
    let path = dir.join("valid_ride.csv");
    let status = Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["ride", "--profile", "lab", "--duration-s", "10", "--out"])
        .arg(&path)
        .stderr(Stdio::null())
        .status()
        .expect("supine ride");
    assert!(status.success());
    std::fs::read_to_string(&path).expect("ride")
}

/// A valid one-subject dataset of 30 s at 200 Hz; its folder and `dataset.toml`'s text.
fn valid_dataset(dir: &Path) -> (PathBuf, String) {
    let ds = dir.join("valid_dataset");
    let settings = SynthSettings {
        subjects: 1,
        duration_s: 30.0,
        seed: 17,
        ..SynthSettings::default()
    };
    write_dataset(&ds, &settings, |_, _| {}).expect("dataset");
    let text = std::fs::read_to_string(ds.join("dataset.toml")).expect("dataset.toml");
    (ds, text)
}

fn preset_params(dir: &Path) -> PathBuf {
    let path = dir.join("valid_params.toml");
    params_file::save(
        &path,
        &ParamFile::preset(supine_core::model::Preset::PaperLitter),
    )
    .expect("params");
    path
}

/// The malformed files every CSV reader gets: (name, file name, content or sparse
/// length, what the error must also say).
enum Content {
    Bytes(Vec<u8>),
    /// A sparse file: these bytes, then NUL bytes up to the length.
    Sparse(Vec<u8>, u64),
}

fn write_content(path: &Path, content: &Content) {
    match content {
        Content::Bytes(bytes) => std::fs::write(path, bytes).expect("write"),
        Content::Sparse(prefix, len) => sparse(path, prefix, *len),
    }
}

/// The hostile and the valid-but-unusual files of a CSV format whose header is `header`
/// and whose valid text is `valid`.
fn csv_files(header: &str, valid: &str) -> Vec<(&'static str, Content, Expectation)> {
    let data_line = valid.lines().nth(1).expect("a data line");
    let cells: Vec<&str> = data_line.split(',').collect();
    let mut huge_value = cells.clone();
    let big = "1".repeat(HUGE_FIELD_BYTES);
    huge_value[1] = &big;
    let mut absurd = cells.clone();
    absurd[3] = "1e300";
    let mut far_time = cells.clone();
    far_time[0] = "1e300";
    let next_line = valid.lines().nth(2).expect("a second data line");
    let nul_field = {
        let mut line = format!("{header}\n").into_bytes();
        line.extend_from_slice(cells[0].as_bytes());
        line.push(b',');
        line.extend(std::iter::repeat_n(0u8, 64));
        line.extend_from_slice(format!(",{}\n", cells[2..].join(",")).as_bytes());
        line
    };
    vec![
        ("empty", Content::Bytes(Vec::new()), refused(&["line 1"])),
        (
            "header only",
            Content::Bytes(format!("{header}\n").into_bytes()),
            refused(&["at least 2 samples"]),
        ),
        (
            "binary garbage",
            Content::Bytes(garbage(1 << 16, 1)),
            refused(&["line 1"]),
        ),
        (
            "NUL bytes, no line end",
            Content::Bytes(vec![0; 1 << 16]),
            refused(&["line 1"]),
        ),
        (
            "NUL bytes in a field",
            Content::Bytes(nul_field),
            refused(&["line 2", "\\0\\0"]),
        ),
        (
            "UTF-8 byte order mark (valid)",
            Content::Bytes(with_bom(valid)),
            Expectation::Accepted,
        ),
        (
            "CRLF line ends (valid)",
            Content::Bytes(crlf(valid).into_bytes()),
            Expectation::Accepted,
        ),
        (
            "2 GiB of NUL bytes (sparse)",
            Content::Sparse(Vec::new(), HUGE_BYTES),
            refused(&["line 1", "at most 4096 bytes"]),
        ),
        (
            "header, then 2 GiB of NUL bytes (sparse)",
            Content::Sparse(format!("{header}\n").into_bytes(), HUGE_BYTES),
            refused(&["line 2", "at most 4096 bytes"]),
        ),
        (
            "a 1 MB field",
            Content::Bytes(format!("{header}\n{}\n", huge_value.join(",")).into_bytes()),
            refused(&["line 2", "at most 4096 bytes"]),
        ),
        (
            "1e300 (beyond f32) in a valid file",
            Content::Bytes(valid.replacen(data_line, &absurd.join(","), 1).into_bytes()),
            refused(&["line 2", "column platform_z", "f32", "\"1e300\""]),
        ),
        (
            "1e300 s (time)",
            Content::Bytes(format!("{header}\n{}\n{next_line}\n", far_time.join(",")).into_bytes()),
            if header.split(',').count() == 4 {
                // A ride: the next row steps back from 1e300 s and is dropped and counted,
                // as the ride reader drops every backward step, which leaves one sample.
                refused(&["expected at least 2 samples, found 1"])
            } else {
                refused(&["line 3", "column time_s", "after 1e300 s"])
            },
        ),
    ]
}

enum Expectation {
    Refused(Vec<String>),
    Accepted,
}

fn refused(needles: &[&str]) -> Expectation {
    Expectation::Refused(needles.iter().map(|s| s.to_string()).collect())
}

impl Expectation {
    fn into_expect(self) -> Expect {
        match self {
            Expectation::Refused(n) => Expect::Refused(n),
            Expectation::Accepted => Expect::Accepted,
        }
    }
}

#[test]
fn rides_given_to_supine_exposure() {
    let dir = tempfile::tempdir().expect("temp dir");
    let valid = valid_ride(dir.path());
    let mut cases = Vec::new();
    for (k, (name, content, expectation)) in csv_files(PLATFORM_HEADER_LINE, &valid)
        .into_iter()
        .enumerate()
    {
        let file = dir.path().join(format!("hostile_ride_{k}.csv"));
        write_content(&file, &content);
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name: name.to_string(),
            args: os(&[
                &"exposure",
                &"--preset",
                &"paper-litter",
                &"--input",
                &rel(&file),
            ]),
            file,
            env: Vec::new(),
            expect: expectation.into_expect(),
        });
    }
    run_suite("ride (supine exposure --input)", &cases);
}

/// Another logger's ride as `--columns` reads it: semicolons, its own header names (with
/// spaces), time in ms, acceleration in g; `lines` data lines of 2 ms.
fn other_logger_ride(lines: usize) -> String {
    let mut text = String::from("Time (ms);acc X;acc Y;acc Z\n");
    for k in 0..lines {
        let t = k as f64;
        text.push_str(&format!(
            "{};{:.5};{:.5};{:.5}\n",
            2 * k,
            0.01 * (0.1 * t).sin(),
            0.02 * (0.13 * t).cos(),
            0.05 * (0.07 * t).sin()
        ));
    }
    text
}

#[test]
fn rides_from_another_logger_given_to_supine_report() {
    let dir = tempfile::tempdir().expect("temp dir");
    let valid = other_logger_ride(4000);
    let header = valid.lines().next().expect("header");
    let body: String = valid.lines().skip(2).map(|l| format!("{l}\n")).collect();
    let with_line_2 = |line2: &[u8]| {
        let mut bytes = format!("{header}\n").into_bytes();
        bytes.extend_from_slice(line2);
        bytes.push(b'\n');
        bytes.extend_from_slice(body.as_bytes());
        bytes
    };
    let with_header = |header: &[u8]| {
        let mut bytes = header.to_vec();
        bytes.push(b'\n');
        bytes.extend(
            valid
                .lines()
                .skip(1)
                .flat_map(|l| format!("{l}\n").into_bytes()),
        );
        bytes
    };
    let huge_field = format!("0;{};0;0", "1".repeat(HUGE_FIELD_BYTES));
    let huge_name = format!("Time (ms);{};acc Y;acc Z", "A".repeat(HUGE_FIELD_BYTES));
    let files = vec![
        (
            "semicolons, ms, g, BOM and CRLF (valid)",
            Content::Bytes(with_bom(&crlf(&valid))),
            Expectation::Accepted,
        ),
        (
            "a 1 MB field",
            Content::Bytes(with_line_2(huge_field.as_bytes())),
            refused(&["line 2", "at most 4096 bytes"]),
        ),
        (
            "a 1 MB header name",
            Content::Bytes(with_header(huge_name.as_bytes())),
            refused(&["line 1", "at most 4096 bytes"]),
        ),
        (
            "terminal escapes and a bell in a field",
            Content::Bytes(with_line_2(b"0;0.1\x1b[31mred\x07;0;0")),
            refused(&[
                "line 2",
                "column acc X",
                "in g",
                "\"0.1\\u{1b}[31mred\\u{7}\"",
            ]),
        ),
        (
            "bytes that are not UTF-8 in a field",
            Content::Bytes(with_line_2(b"0;\xff\xfe;0;0")),
            refused(&["line 2", "column acc X", "\"\\xff\\xfe\""]),
        ),
        (
            "a terminal escape in a header name",
            Content::Bytes(with_header(b"acc\x1b[2J X;Time (ms);acc Y;acc Z")),
            refused(&["line 1", "--columns x=", "\"acc X\"", "\"acc\\u{1b}[2J X\""]),
        ),
        (
            "header, then 2 GiB of NUL bytes (sparse)",
            Content::Sparse(format!("{header}\n").into_bytes(), HUGE_BYTES),
            refused(&["line 2", "at most 4096 bytes"]),
        ),
    ];
    let mut cases = Vec::new();
    for (k, (name, content, expectation)) in files.into_iter().enumerate() {
        let file = dir.path().join(format!("other_logger_{k}.csv"));
        write_content(&file, &content);
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name: name.to_string(),
            args: os(&[
                &"report",
                &"--preset",
                &"paper-litter",
                &"--columns",
                &"time=Time (ms),x=acc X,y=acc Y,z=acc Z",
                &"--time-unit",
                &"ms",
                &"--units",
                &"g",
                &"--out",
                &format!("report_{k}"),
                &"--input",
                &rel(&file),
            ]),
            file,
            env: Vec::new(),
            expect: expectation.into_expect(),
        });
    }
    run_suite("another logger's ride (supine report --columns)", &cases);
}

/// The manifest an output folder keeps of the files supine wrote there: read before
/// anything runs, so a hostile one is refused at once.
#[test]
fn output_folder_manifests_read_by_supine_demo() {
    let dir = tempfile::tempdir().expect("temp dir");
    let files = [
        (
            "2 GiB of NUL bytes (sparse)",
            Content::Sparse(Vec::new(), HUGE_BYTES),
            vec!["at most 65536 bytes"],
        ),
        (
            "bytes that are not UTF-8",
            Content::Bytes(b"report.html\n\xff\x1b\n".to_vec()),
            vec!["line 2, column 1", "expected UTF-8", "\"\\xff\""],
        ),
    ];
    let mut cases = Vec::new();
    for (k, (name, content, needles)) in files.into_iter().enumerate() {
        let out = dir.path().join(format!("demo_{k}"));
        std::fs::create_dir_all(&out).expect("folder");
        let file = out.join(".supine-files");
        write_content(&file, &content);
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name: name.to_string(),
            args: os(&[&"demo", &"--out", &rel(&out)]),
            file,
            env: Vec::new(),
            expect: Expect::Refused(needles.iter().map(|n| n.to_string()).collect()),
        });
    }
    run_suite("output folder manifest (supine demo --out)", &cases);
}

#[test]
fn recordings_given_to_supine_predict() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (ds, _) = valid_dataset(dir.path());
    let valid = std::fs::read_to_string(ds.join("s1_rigid.csv")).expect("recording");
    let params = preset_params(dir.path());
    let mut cases = Vec::new();
    for (k, (name, content, expectation)) in csv_files(HEADER_LINE, &valid).into_iter().enumerate()
    {
        let file = dir.path().join(format!("hostile_recording_{k}.csv"));
        write_content(&file, &content);
        let out = dir.path().join(format!("predicted_{k}.csv"));
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name: name.to_string(),
            args: os(&[
                &"predict",
                &"--params",
                &params,
                &"--input",
                &rel(&file),
                &"--out",
                &out,
            ]),
            file,
            env: Vec::new(),
            expect: expectation.into_expect(),
        });
    }
    run_suite("recording (supine predict --input)", &cases);
}

/// Parameter files: (name, content, expectation), given to `supine exposure --params`.
fn parameter_files(valid: &str) -> Vec<(String, Content, Expectation)> {
    let header: String = valid
        .lines()
        .take_while(|l| l.starts_with('#'))
        .map(|l| format!("{l}\n"))
        .collect();
    let huge_key = format!("{} = 1\n{valid}", "k".repeat(60_000));
    let absurd_height = valid.replacen("height_m = ", "height_m = 1e300 #", 1);
    vec![
        (
            "empty".into(),
            Content::Bytes(Vec::new()),
            refused(&["subject"]),
        ),
        (
            "header only (the comment block)".into(),
            Content::Bytes(header.into_bytes()),
            refused(&["subject"]),
        ),
        (
            "binary garbage".into(),
            Content::Bytes(garbage(1 << 14, 2)),
            refused(&["expected UTF-8"]),
        ),
        (
            "NUL bytes".into(),
            Content::Bytes(vec![0; 1 << 14]),
            refused(&["line 1"]),
        ),
        (
            "UTF-8 byte order mark (valid)".into(),
            Content::Bytes(with_bom(valid)),
            Expectation::Accepted,
        ),
        (
            "CRLF line ends (valid)".into(),
            Content::Bytes(crlf(valid).into_bytes()),
            Expectation::Accepted,
        ),
        (
            "2 GiB of NUL bytes (sparse)".into(),
            Content::Sparse(Vec::new(), HUGE_BYTES),
            refused(&["at most 65536 bytes"]),
        ),
        (
            "a 1 MB field".into(),
            Content::Bytes(
                format!(
                    "{valid}\n[fit]\nnote = \"{}\"\n",
                    "n".repeat(HUGE_FIELD_BYTES)
                )
                .into_bytes(),
            ),
            refused(&["at most 65536 bytes"]),
        ),
        (
            "a 60 kB key".into(),
            Content::Bytes(huge_key.into_bytes()),
            refused(&["line 1", "... (60000 characters)"]),
        ),
        (
            "1e300 (height)".into(),
            Content::Bytes(absurd_height.into_bytes()),
            refused(&["line ", "height_m"]),
        ),
        (
            "an empty joint alert table (neck_z = { })".into(),
            Content::Bytes(format!("{valid}\n[device.joint_alerts]\nneck_z = {{ }}\n").into_bytes()),
            refused(&["line ", "joint_alerts.neck_z: an empty table sets no alert"]),
        ),
        (
            "only [device] tables, no base".into(),
            Content::Bytes(b"[device.joint_alerts]\nneck_z = { excursion_m = 0.01 }\n".to_vec()),
            refused(&["missing field `subject`", "base = \"paper-litter\""]),
        ),
        (
            "only [device] tables over base = \"paper-litter\" (valid)".into(),
            Content::Bytes(
                b"base = \"paper-litter\"\n[device.joint_alerts]\nneck_z = { excursion_m = 0.01 }\n"
                    .to_vec(),
            ),
            Expectation::Accepted,
        ),
        (
            "base naming no preset".into(),
            Content::Bytes(b"base = \"paper-boat\"\n".to_vec()),
            refused(&["line 1, column 1: base: expected a preset", "\"paper-boat\""]),
        ),
    ]
}

/// `[device]` values the device refuses, appended to a valid file: (name, table, the key
/// the error must name).
const DEVICE_CASES: [(&str, &str, &str); 11] = [
    (
        "telemetry_decimation 0",
        "[device]\ntelemetry_decimation = 0\n",
        "device.telemetry_decimation",
    ),
    (
        "unordered thresholds",
        "[device.alerts]\nrunning_rms_m_s2 = [0.8, 0.5, 1.25]\nvdv_m_s175 = [8.5, 17.0, 21.0]\n\
         hysteresis = 0.2\nraise_dwell_s = 0.5\nclear_dwell_s = 5.0\n",
        "device.alerts.running_rms_m_s2",
    ),
    (
        "hysteresis 2",
        "[device.alerts]\nrunning_rms_m_s2 = [0.5, 0.8, 1.25]\nvdv_m_s175 = [8.5, 17.0, 21.0]\n\
         hysteresis = 2\nraise_dwell_s = 0.5\nclear_dwell_s = 5.0\n",
        "device.alerts.hysteresis",
    ),
    (
        "negative full scale",
        "[device.sensor_checks]\nfull_scale_m_s2 = -1\nstuck_after_s = 1\nclear_after_s = 1\n",
        "device.sensor_checks.full_scale_m_s2",
    ),
    (
        "NaN threshold",
        "[device.alerts]\nrunning_rms_m_s2 = [0.5, 0.8, 1.25]\nvdv_m_s175 = [nan, 17.0, 21.0]\n\
         hysteresis = 0.2\nraise_dwell_s = 0.5\nclear_dwell_s = 5.0\n",
        "device.alerts.vdv_m_s175",
    ),
    (
        "a matrix that is not a rotation",
        "[device.mounting]\nsensor_to_litter = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]\n\
         gravity_m_s2 = 9.8\n",
        "device.mounting.sensor_to_litter",
    ),
    (
        "1e300 full scale (beyond f32)",
        "[device.sensor_checks]\nfull_scale_m_s2 = 1e300\nstuck_after_s = 1\nclear_after_s = 1\n",
        "device.sensor_checks.full_scale_m_s2",
    ),
    (
        "a joint threshold in the other unit",
        "[device.joint_alerts.neck_x]\nexcursion_rad = 0.1\n",
        "device.joint_alerts.neck_x.excursion_rad",
    ),
    (
        "a negative joint threshold",
        "[device.joint_alerts.neck_ry]\nexcursion_rad = -0.05\n",
        "device.joint_alerts.neck_ry.excursion_rad",
    ),
    (
        "a joint threshold for an output not read",
        "[device]\njoint_outputs = [\"neck_x\"]\n[device.joint_alerts.low_back_z]\n\
         running_rms_m = 0.002\n",
        "device.joint_alerts.low_back_z.running_rms_m",
    ),
    (
        "joint alert hysteresis 2",
        "[device.joint_alerts]\nhysteresis = 2\n[device.joint_alerts.neck_x]\nexcursion_m = 0.005\n",
        "device.joint_alerts.hysteresis",
    ),
];

#[test]
fn parameter_files_given_as_params() {
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = dir.path().join("ride.csv");
    std::fs::write(&ride, valid_ride(dir.path())).expect("ride");
    let valid = std::fs::read_to_string(preset_params(dir.path())).expect("params");
    let mut cases = Vec::new();
    for (k, (name, content, expectation)) in parameter_files(&valid).into_iter().enumerate() {
        let file = dir.path().join(format!("hostile_params_{k}.toml"));
        write_content(&file, &content);
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name,
            args: os(&[&"exposure", &"--params", &rel(&file), &"--input", &ride]),
            file,
            env: Vec::new(),
            expect: expectation.into_expect(),
        });
    }
    run_suite("parameter file (--params)", &cases);
}

#[test]
fn device_tables_the_device_refuses_are_named_by_file_line_and_key() {
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = dir.path().join("ride.csv");
    std::fs::write(&ride, valid_ride(dir.path())).expect("ride");
    let valid = std::fs::read_to_string(preset_params(dir.path())).expect("params");
    let first_line = valid.lines().count() + 1;
    let mut cases = Vec::new();
    for (k, (name, table, key)) in DEVICE_CASES.into_iter().enumerate() {
        let file = dir.path().join(format!("hostile_device_{k}.toml"));
        std::fs::write(&file, format!("{valid}{table}")).expect("write");
        // The key's line: the table's lines start right after the valid file.
        let leaf = key.rsplit('.').next().expect("a key");
        let offset = table
            .lines()
            .position(|l| l.starts_with(leaf))
            .expect("the key in the table");
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name: name.to_string(),
            args: os(&[&"exposure", &"--params", &rel(&file), &"--input", &ride]),
            file,
            env: Vec::new(),
            expect: Expect::Refused(vec![
                format!("line {}, column 1: {key}: ", first_line + offset),
                "found ".to_string(),
            ]),
        });
    }
    run_suite("parameter file [device] values (--params)", &cases);
}

#[test]
fn dataset_descriptions_given_to_fit_and_transmissibility() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (valid_ds, valid) = valid_dataset(dir.path());
    let recording = valid_ds.join("s1_rigid.csv");
    let litter = valid_ds.join("s1_litter.csv");
    // Recordings named by absolute path, so that every hostile folder can use them.
    let valid = valid
        .replace(
            "\"s1_rigid.csv\"",
            &format!("{:?}", recording.display().to_string()),
        )
        .replace(
            "\"s1_litter.csv\"",
            &format!("{:?}", litter.display().to_string()),
        );
    assert!(valid.contains(&recording.display().to_string()), "{valid}");
    let contents: Vec<(String, Content, Expectation)> = vec![
        (
            "empty".into(),
            Content::Bytes(Vec::new()),
            refused(&["subject"]),
        ),
        (
            "header only ([[subject]])".into(),
            Content::Bytes(b"[[subject]]\n".to_vec()),
            refused(&["id"]),
        ),
        (
            "binary garbage".into(),
            Content::Bytes(garbage(1 << 14, 3)),
            refused(&["expected UTF-8"]),
        ),
        (
            "NUL bytes".into(),
            Content::Bytes(vec![0; 1 << 14]),
            refused(&["dataset.toml:1:"]),
        ),
        (
            "UTF-8 byte order mark (valid)".into(),
            Content::Bytes(with_bom(&valid)),
            Expectation::Accepted,
        ),
        (
            "CRLF line ends (valid)".into(),
            Content::Bytes(crlf(&valid).into_bytes()),
            Expectation::Accepted,
        ),
        (
            "2 GiB of NUL bytes (sparse)".into(),
            Content::Sparse(Vec::new(), HUGE_BYTES),
            refused(&["at most 1048576 bytes"]),
        ),
        (
            "a 1 MB field (height)".into(),
            Content::Bytes(
                format!(
                    "[[subject]]\nid = \"s1\"\nheight_m = \"{}\"\nmass_kg = 80\n",
                    "9".repeat(HUGE_FIELD_BYTES)
                )
                .into_bytes(),
            ),
            refused(&["3:", "height_m", "characters)"]),
        ),
        (
            "a 1 MB subject id".into(),
            Content::Bytes(
                format!(
                    "[[subject]]\nid = \"{}\"\nheight_m = -1\nmass_kg = 80\n",
                    "s".repeat(HUGE_FIELD_BYTES)
                )
                .into_bytes(),
            ),
            refused(&["3:", "height_m", "(1000000 bytes)"]),
        ),
        (
            "a 1 MB recording name".into(),
            Content::Bytes(
                format!(
                    "[[subject]]\nid = \"s1\"\nheight_m = 1.8\nmass_kg = 80\nrigid = \"{}\"\n",
                    "r".repeat(HUGE_FIELD_BYTES)
                )
                .into_bytes(),
            ),
            refused(&["5:", "rigid", "found 1000000 bytes"]),
        ),
        (
            "1e300 (height)".into(),
            Content::Bytes(
                valid
                    .replacen("height_m = ", "height_m = 1e300 #", 1)
                    .into_bytes(),
            ),
            refused(&["height_m"]),
        ),
    ];
    let mut cases = Vec::new();
    for (k, (name, content, expectation)) in contents.into_iter().enumerate() {
        let ds = dir.path().join(format!("hostile_dataset_{k}"));
        std::fs::create_dir(&ds).expect("folder");
        let file = ds.join("dataset.toml");
        write_content(&file, &content);
        let accepted = matches!(expectation, Expectation::Accepted);
        let h = ds.join("H.csv");
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name: format!("{name}, transmissibility"),
            args: os(&[
                &"transmissibility",
                &"--dataset",
                &rel(&ds),
                &"--case",
                &"rigid",
                &"--out",
                &h,
            ]),
            file: file.clone(),
            env: Vec::new(),
            expect: expectation.into_expect(),
        });
        // The fit of a valid file takes a while: `fit` runs the refusals only.
        if !accepted {
            let Expect::Refused(needles) = &cases.last().expect("a case").expect else {
                unreachable!("a refusal");
            };
            let needles = needles.clone();
            let out = ds.join("fit.toml");
            cases.push(Case {
                cwd: dir.path().to_path_buf(),
                name: format!("{name}, fit"),
                args: os(&[
                    &"fit",
                    &"--dataset",
                    &rel(&ds),
                    &"--case",
                    &"rigid",
                    &"--out",
                    &out,
                ]),
                file,
                env: Vec::new(),
                expect: Expect::Refused(needles),
            });
        }
    }
    run_suite("dataset.toml (supine transmissibility, supine fit)", &cases);
}

/// The development key's text.
fn dev_key() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    std::fs::read_to_string(root.join("firmware/keys/dev-device.key")).expect("dev key")
}

const NO_PORT: &str = "/nonexistent/supine-hostile-tty";

#[test]
fn key_files_given_to_supine_flash() {
    let dir = tempfile::tempdir().expect("temp dir");
    let key = dev_key();
    let digits = key.trim();
    let split = format!("{}\n{}\n", &digits[..32], &digits[32..]);
    let contents: Vec<(&str, Content, Option<&str>)> = vec![
        (
            "empty",
            Content::Bytes(Vec::new()),
            Some("found 0 characters"),
        ),
        (
            "header only (half a key)",
            Content::Bytes(format!("{}\n", &digits[..32]).into_bytes()),
            Some("found 32 characters"),
        ),
        (
            "binary garbage",
            Content::Bytes(garbage(512, 4)),
            Some("expected UTF-8"),
        ),
        ("NUL bytes", Content::Bytes(vec![0; 512]), Some("found 512")),
        (
            "UTF-8 byte order mark (valid)",
            Content::Bytes(with_bom(&key)),
            None,
        ),
        (
            "CRLF line ends (valid)",
            Content::Bytes(crlf(&split).into_bytes()),
            None,
        ),
        (
            "2 GiB of NUL bytes (sparse)",
            Content::Sparse(Vec::new(), HUGE_BYTES),
            Some("at most 1024 bytes"),
        ),
        (
            "a 1 MB field",
            Content::Bytes("a".repeat(HUGE_FIELD_BYTES).into_bytes()),
            Some("at most 1024 bytes"),
        ),
        (
            "1e300",
            Content::Bytes(b"1e300\n".to_vec()),
            Some("found 5"),
        ),
    ];
    let mut cases = Vec::new();
    for (k, (name, content, needle)) in contents.into_iter().enumerate() {
        let file = dir.path().join(format!("hostile_{k}.key"));
        write_content(&file, &content);
        let state = dir.path().join(format!("state_{k}"));
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name: name.to_string(),
            args: os(&[
                &"flash",
                &"--preset",
                &"paper-litter",
                &"--serial",
                &NO_PORT,
                &"--key",
                &rel(&file),
            ]),
            file,
            env: vec![("SUPINE_STATE_DIR".into(), state)],
            expect: match needle {
                Some(n) => Expect::Refused(vec![n.to_string()]),
                None => Expect::AcceptedThenFailsOn(NO_PORT.to_string()),
            },
        });
    }
    run_suite("device key file (supine flash --key)", &cases);
}

#[test]
fn update_counter_files_read_by_supine_flash() {
    let dir = tempfile::tempdir().expect("temp dir");
    let key = dir.path().join("dev.key");
    std::fs::write(&key, dev_key()).expect("key");
    let contents: Vec<(&str, Content, Option<&str>)> = vec![
        ("empty", Content::Bytes(Vec::new()), Some("found \"\"")),
        (
            "binary garbage",
            Content::Bytes(garbage(512, 5)),
            Some("expected UTF-8"),
        ),
        ("NUL bytes", Content::Bytes(vec![0; 512]), Some("\\0\\0")),
        (
            "UTF-8 byte order mark (valid)",
            Content::Bytes(with_bom("5\n")),
            None,
        ),
        (
            "CRLF line end (valid)",
            Content::Bytes(b"5\r\n".to_vec()),
            None,
        ),
        (
            "2 GiB of NUL bytes (sparse)",
            Content::Sparse(Vec::new(), HUGE_BYTES),
            Some("at most 1024 bytes"),
        ),
        (
            "a 1 MB field",
            Content::Bytes("7".repeat(HUGE_FIELD_BYTES).into_bytes()),
            Some("at most 1024 bytes"),
        ),
        (
            "1e300",
            Content::Bytes(b"1e300\n".to_vec()),
            Some("\"1e300\""),
        ),
    ];
    let mut cases = Vec::new();
    for (k, (name, content, needle)) in contents.into_iter().enumerate() {
        let state = dir.path().join(format!("state_{k}"));
        std::fs::create_dir(&state).expect("folder");
        let file = state.join("upload-counter");
        write_content(&file, &content);
        cases.push(Case {
            cwd: dir.path().to_path_buf(),
            name: name.to_string(),
            args: os(&[
                &"flash",
                &"--preset",
                &"paper-litter",
                &"--serial",
                &NO_PORT,
                &"--key",
                &key,
            ]),
            file,
            env: vec![("SUPINE_STATE_DIR".into(), rel(&state).to_path_buf())],
            expect: match needle {
                Some(n) => Expect::Refused(vec![n.to_string()]),
                None => Expect::AcceptedThenFailsOn(NO_PORT.to_string()),
            },
        });
    }
    run_suite("update counter file (supine flash)", &cases);
}

/// A character device that fails every write as `/dev/full` does: a node of our own
/// when this test may make one (root), so that a regression replaces the test's node
/// and not the system's; else `/dev/full` itself (which a non-root run cannot replace).
fn full_device(dir: &Path) -> PathBuf {
    use nix::sys::stat::{Mode, SFlag, makedev, mknod};
    let node = dir.join("full");
    match mknod(
        &node,
        SFlag::S_IFCHR,
        Mode::from_bits_truncate(0o666),
        makedev(1, 7),
    ) {
        Ok(()) => node,
        Err(_) => PathBuf::from("/dev/full"),
    }
}

fn is_kind(path: &Path, want: fn(&std::fs::FileType) -> bool) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| want(&m.file_type()))
}

#[test]
fn outputs_that_are_devices_pipes_folders_or_a_full_disk() {
    use std::os::unix::fs::FileTypeExt as _;
    let dir = tempfile::tempdir().expect("temp dir");
    let cwd = dir.path().to_path_buf();
    let full = full_device(dir.path());
    let mut cases = Vec::new();
    for (command, extra) in [
        ("ride", vec!["--profile", "lab", "--duration-s", "10"]),
        ("model", vec!["--preset", "paper-litter"]),
        ("weighting", vec!["--weighting", "wk"]),
    ] {
        let mut args: Vec<OsString> = os(&[&command]);
        args.extend(extra.iter().map(OsString::from));
        args.extend(os(&[&"--out", &full]));
        cases.push(Case {
            cwd: cwd.clone(),
            name: format!("{command} --out a full device"),
            args,
            file: full.clone(),
            env: Vec::new(),
            expect: Expect::Refused(vec![": cannot write: No space left on device".to_string()]),
        });
    }
    let folder = dir.path().join("a_folder.csv");
    std::fs::create_dir(&folder).expect("folder");
    cases.push(Case {
        cwd: cwd.clone(),
        name: "ride --out a folder".to_string(),
        args: os(&[&"ride", &"--profile", &"lab", &"--out", &rel(&folder)]),
        file: folder.clone(),
        env: Vec::new(),
        expect: Expect::Refused(vec!["is a folder".to_string()]),
    });
    // A tiny mass, echoed in exponent form within the README's limit.
    let ride = dir.path().join("ride.csv");
    std::fs::write(&ride, valid_ride(dir.path())).expect("ride");
    cases.push(Case {
        cwd: cwd.clone(),
        name: "--mass-kg=1e-320 echoed short".to_string(),
        args: os(&[
            &"exposure",
            &"--preset",
            &"paper-litter",
            &"--input",
            &rel(&ride),
            &"--mass-kg=1e-320",
        ]),
        file: PathBuf::from("--mass-kg"),
        env: Vec::new(),
        expect: Expect::Refused(vec!["--mass-kg 1e-320: expected".to_string()]),
    });
    // A QEMU that never opens its UART: given up on, not waited for forever.
    let hang = dir.path().join("hanging-qemu");
    std::fs::write(&hang, "#!/bin/sh\nexec sleep 600\n").expect("script");
    let mut mode = std::fs::metadata(&hang).expect("script").permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut mode, 0o755);
    std::fs::set_permissions(&hang, mode).expect("chmod");
    cases.push(Case {
        cwd: cwd.clone(),
        name: "SUPINE_QEMU that never opens the UART".to_string(),
        args: os(&[
            &"replay",
            &"--qemu",
            &"--preset",
            &"paper-litter",
            &"--input",
            &rel(&ride),
            &"--out",
            &"replayed.csv",
        ]),
        file: hang.clone(),
        env: vec![("SUPINE_QEMU".to_string(), hang.clone())],
        expect: Expect::Refused(vec!["did not open its UART socket within 20 s".to_string()]),
    });
    // A dead run's staging file beside an output is swept by the next write there.
    let stale = dir.path().join(".swept.csv.2147483647.partial");
    std::fs::write(&stale, "half").expect("stale");
    cases.push(Case {
        cwd: cwd.clone(),
        name: "a dead run's .partial beside --out (swept)".to_string(),
        args: os(&[
            &"ride",
            &"--profile",
            &"lab",
            &"--duration-s",
            &"10",
            &"--out",
            &"swept.csv",
        ]),
        file: stale.clone(),
        env: Vec::new(),
        expect: Expect::Accepted,
    });
    // synth into a folder where a file it writes cannot be: it leaves nothing of its own.
    let half = dir.path().join("half_made");
    std::fs::create_dir_all(half.join("s1_rigid.csv")).expect("blocking folder");
    cases.push(Case {
        cwd: cwd.clone(),
        name: "synth that fails half-way (--force)".to_string(),
        args: os(&[
            &"synth",
            &"--out",
            &rel(&half),
            &"--subjects",
            &"1",
            &"--duration-s",
            &"30",
            &"--force",
        ]),
        file: half.join("s1_rigid.csv"),
        env: Vec::new(),
        expect: Expect::Refused(vec!["is a folder".to_string()]),
    });
    run_suite(
        "outputs (devices, folders, a full disk, QEMU, leftovers)",
        &cases,
    );
    // What the cases must leave behind.
    assert!(
        is_kind(&full, |t| t.is_char_device()),
        "{} replaced",
        full.display()
    );
    assert!(!stale.exists(), "the dead run's staging file stays");
    let left: Vec<String> = std::fs::read_dir(&half)
        .expect("folder")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, ["s1_rigid.csv"], "synth left a half-made dataset");
}

#[test]
fn fifos_are_written_through_not_replaced() {
    let _one_at_a_time = one_at_a_time();
    use std::os::unix::fs::FileTypeExt as _;
    let dir = tempfile::tempdir().expect("temp dir");
    let mut held = 0;
    for (k, command) in [
        vec!["ride", "--profile", "lab", "--duration-s", "10"],
        vec!["model", "--preset", "paper-litter"],
        vec!["weighting", "--weighting", "wk"],
    ]
    .into_iter()
    .enumerate()
    {
        let fifo = dir.path().join(format!("pipe_{k}"));
        nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).expect("mkfifo");
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).expect("read the FIFO"))
        };
        let out = Command::new(env!("CARGO_BIN_EXE_supine"))
            .args(&command)
            .arg("--out")
            .arg(&fifo)
            .output()
            .expect("supine");
        let got = reader.join().expect("reader");
        let ok = out.status.success() && got.len() > 100 && is_kind(&fifo, |t| t.is_fifo());
        println!(
            "FIFO | {} --out a FIFO | {} | {} bytes through",
            command[0],
            if ok { "held" } else { "BROKE" },
            got.len()
        );
        assert!(
            ok,
            "{command:?}: {:?} {}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        held += 1;
    }
    println!("FIFO: tried 3, held {held}");
}

#[test]
fn a_closed_stdout_ends_every_printing_command_quietly() {
    let _one_at_a_time = one_at_a_time();
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = dir.path().join("ride.csv");
    std::fs::write(&ride, valid_ride(dir.path())).expect("ride");
    let ride = ride.to_string_lossy().into_owned();
    let commands: Vec<Vec<&str>> = vec![
        vec!["params", "--preset", "paper-litter"],
        vec!["modes", "--preset", "paper-litter"],
        vec!["completions", "bash"],
        vec!["calibrate", "--at-rest-m-s2", "0.1,-0.2,9.8"],
        vec!["exposure", "--preset", "paper-litter", "--input", &ride],
        vec![
            "exposure",
            "--preset",
            "paper-litter",
            "--input",
            &ride,
            "--json",
        ],
        vec!["--help"],
    ];
    let mut held = 0;
    for args in &commands {
        // The reader goes away before supine writes: every write meets a closed pipe.
        let (read_end, write_end) = nix::unistd::pipe().expect("pipe");
        drop(read_end);
        let out = Command::new(env!("CARGO_BIN_EXE_supine"))
            .args(args)
            .stdout(Stdio::from(write_end))
            .stderr(Stdio::piped())
            .output()
            .expect("supine");
        let stderr = String::from_utf8_lossy(&out.stderr);
        let quiet = matches!(out.status.code(), Some(0) | Some(141)) && stderr.is_empty();
        println!(
            "closed stdout | supine {} | {} | {:?} {}",
            args.join(" "),
            if quiet { "held" } else { "BROKE" },
            out.status.code(),
            first_chars(&stderr, 120)
        );
        if quiet {
            held += 1;
        }
    }
    // A full disk behind stdout is an error that names stdout.
    let full = full_device(dir.path());
    let out = Command::new(env!("CARGO_BIN_EXE_supine"))
        .args(["params", "--preset", "paper-litter"])
        .stdout(
            std::fs::OpenOptions::new()
                .write(true)
                .open(&full)
                .expect("open"),
        )
        .output()
        .expect("supine");
    let stderr = String::from_utf8_lossy(&out.stderr);
    let named = out.status.code() == Some(1)
        && stderr == "supine: stdout: cannot write: No space left on device (os error 28)\n";
    println!(
        "closed stdout | supine params > a full device | {} | {}",
        if named { "held" } else { "BROKE" },
        stderr.trim_end()
    );
    if named {
        held += 1;
    }
    let tried = commands.len() + 1;
    println!("closed or full stdout: tried {tried}, held {held}");
    assert_eq!(held, tried);
}
