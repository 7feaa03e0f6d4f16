//! A device session re-analysed on the host (issue 15, item 4): `supine monitor --qemu
//! --log` asks the firmware for its input stream and writes it as a ride beside the
//! telemetry; `supine report --input LOG.csv` recomputes everything from that ride and
//! must match the device's own values bit for bit (the same f32 code on the same inputs)
//! with identical events. The input file itself is checked against the ride rounded to the
//! input resolution in f64, independently of the core's code; and a log without its input
//! stream, or re-analysed with another patient, is refused with one line.

use std::path::Path;

use supine_host::io::recording::read_input;
use supine_qemu_tests::{firmware, monitor_to_log, rough_ride, run_supine};

fn s(p: &Path) -> String {
    p.to_str().expect("utf-8 path").to_owned()
}

#[test]
fn a_monitor_log_re_analysed_by_report_matches_the_device_bit_for_bit() {
    firmware(supine_host::device::firmware::PRODUCT_BINARY);
    let dir = tempfile::tempdir().expect("temp dir");
    let ride = rough_ride(dir.path());
    let log = dir.path().join("log.csv");
    let (ok, stdout, stderr) = monitor_to_log(&ride, &log);
    println!("stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(ok, "monitor failed: {stderr}");
    let input = dir.path().join("log.input.csv");
    assert!(
        stderr.contains(&format!("{}", input.display())),
        "the input file is named: {stderr}"
    );
    assert!(!stderr.contains("the input stream lost"), "{stderr}");

    // The input file: the ride's samples rounded to 2^-9 m/s^2 (f64 arithmetic), exactly.
    let (recording, _) = read_input(&ride).expect("ride reads");
    let (streamed, _) = read_input(&input).expect("the input file reads as a ride");
    assert_eq!(streamed.len(), recording.len());
    let mut rounded_away = 0;
    for axis in 0..3 {
        for (k, (&sent, &got)) in recording.platform_m_s2[axis]
            .iter()
            .zip(&streamed.platform_m_s2[axis])
            .enumerate()
        {
            let expected = (f64::from(sent as f32) * 512.0).round_ties_even() / 512.0;
            assert_eq!(got, expected, "axis {axis} sample {k}");
            rounded_away += usize::from(got != f64::from(sent as f32));
        }
    }
    assert!(rounded_away > 0, "the ride was not already on the grid");
    assert_eq!(streamed.sample_rate_hz(), recording.sample_rate_hz());

    let out = dir.path().join("report");
    let (ok, stdout, stderr) = run_supine(&[
        "report",
        "--input",
        &s(&log),
        "--preset",
        "paper-litter",
        "--out",
        &s(&out),
        "--json",
    ]);
    assert!(ok, "report failed: {stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let check = &json["device_check"];
    println!("device_check: {check}");
    assert_eq!(check["head_diff_f32_m_s2"], 0.0, "{check}");
    assert_eq!(check["rms_diff_m_s2"], 0.0, "{check}");
    assert_eq!(check["events_agree"], true, "{check}");
    assert_eq!(check["records_complete"], true, "{check}");
    assert_eq!(check["agree"], true, "{check}");
    assert!(
        check["device_events"].as_u64().expect("a count") > 0,
        "{check}"
    );
    assert_eq!(check["samples"].as_u64(), Some(recording.len() as u64));
    // The f64 model on the same input, to its documented accuracy.
    assert!(
        check["head_diff_f64_m_s2"].as_f64().expect("finite") < 1e-4,
        "{check}"
    );
    assert_eq!(json["legs"][0]["input"], s(&input));
    let page = std::fs::read_to_string(out.join("report.html")).expect("report.html");
    assert!(page.contains("The device versus the host"));
    assert!(page.contains("the device and the host agree"));

    // Another patient: refused, naming the session file and the identity expected.
    let (ok, _, stderr) = run_supine(&[
        "report",
        "--input",
        &s(&log),
        "--preset",
        "paper-litter",
        "--height-m",
        "1.6",
        "--mass-kg",
        "52",
        "--out",
        &s(&out),
    ]);
    assert!(!ok);
    let session = dir.path().join("log.session.json");
    assert!(
        stderr.contains(&format!("{}: params_identity", session.display()))
            && stderr.contains("patient 1.6 m, 52 kg"),
        "{stderr}"
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");

    // Without its input stream: refused, saying so.
    std::fs::remove_file(&input).expect("remove the input file");
    let (ok, _, stderr) = run_supine(&[
        "report",
        "--input",
        &s(&log),
        "--preset",
        "paper-litter",
        "--out",
        &s(&out),
    ]);
    assert!(!ok);
    assert!(
        stderr.contains("logged without the input stream") && stderr.contains("log.input.csv"),
        "{stderr}"
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
}

/// What the stream costs at 500 Hz on the 20 s rough-road ride, the shipping telemetry
/// rate (the preset's default, 100 Hz): instructions per sample with it off and on (QEMU
/// `-icount`), and bytes per second on the link, counted from the frames the device sent.
/// The streamed inputs must be exactly the host pipeline's (BENCHMARKS.md quotes the
/// printed figures).
#[test]
fn the_input_stream_costs_on_the_device_and_the_link_at_500_hz() {
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;
    use std::time::Duration;
    use supine_core::model::Preset;
    use supine_core::protocol::{
        DeviceFrame, DeviceToHost, HostToDevice, MAX_FRAME_LEN, encode_frame,
    };
    use supine_host::device::device_params;
    use supine_host::device::replay::{Outgoing, SessionConfig, sample_messages, session};
    use supine_host::exposure::reference;
    use supine_host::io::params_file::ParamFile;

    let dir = tempfile::tempdir().expect("temp dir");
    let ride = rough_ride(dir.path());
    let (recording, _) = read_input(&ride).expect("ride reads");
    let samples = recording.platform_samples();
    let fs = recording.sample_rate_hz();
    let file = ParamFile::preset(Preset::PaperLitter);
    let params = device_params::build(&file, fs).expect("params");
    let blob = device_params::encode(&params).expect("blob");
    let config = SessionConfig {
        kernel: firmware(supine_host::device::firmware::PRODUCT_BINARY),
        blob: Some(blob),
        icount: true,
        timeout: Duration::from_secs(300),
    };
    let frame_len = |message: DeviceToHost| {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let frame = DeviceFrame { seq: 0, message };
        encode_frame(&frame, &mut buf).expect("fits").len()
    };
    let mut figures = Vec::new();
    for stream in [false, true] {
        let mut script = Vec::new();
        if stream {
            script.push(Outgoing::Message(HostToDevice::StreamInput {
                enabled: true,
            }));
        }
        script.extend(sample_messages(0, &samples));
        script.push(Outgoing::Message(HostToDevice::GetStatus));
        let stop = Arc::new(AtomicBool::new(false));
        let run = session(&config, script, &stop).expect("session");
        let status = run.status();
        assert_eq!(status.samples_processed, samples.len() as u32);
        assert_eq!(run.link.lost_frames, 0);
        let mut streamed = Vec::new();
        let mut input_bytes = 0;
        for m in &run.other {
            if let DeviceToHost::Input(batch) = m {
                streamed.extend(batch.samples().expect("decodes").iter().map(|(_, c)| *c));
                input_bytes += frame_len(m.clone());
            }
        }
        // Sequence numbers of up to 3 bytes in a 20 s run, as in a long one up to 2^21.
        let telemetry_bytes: usize = run
            .telemetry
            .iter()
            .map(|t| frame_len(DeviceToHost::Telemetry(*t)))
            .sum();
        let seconds = samples.len() as f64 / fs;
        if stream {
            let host = reference::pipeline(
                &params,
                &(0..samples.len() as u32).collect::<Vec<_>>(),
                &samples,
            );
            assert_eq!(
                streamed, host.input_counts,
                "the stream is the pipeline's input"
            );
        } else {
            assert!(streamed.is_empty());
        }
        println!(
            "stream {}: instructions_per_sample {:.0}, stack_used_bytes {}, telemetry {:.0} B/s, input {:.0} B/s ({:.2} B a sample), link {:.0} B/s of 11,520 (115.2 kbit/s)",
            if stream { "on" } else { "off" },
            run.instructions_per_sample(),
            status.stack_used_bytes,
            telemetry_bytes as f64 / seconds,
            input_bytes as f64 / seconds,
            input_bytes as f64 / samples.len() as f64,
            (telemetry_bytes + input_bytes) as f64 / seconds,
        );
        figures.push(run.instructions_per_sample());
    }
    // The stream on costs a frame a block: 158 instructions a sample when measured
    // (BENCHMARKS.md); a regression guard, not a budget.
    assert!(figures[1] > figures[0], "{figures:?}");
    assert!(figures[1] - figures[0] < 200.0, "{figures:?}");
}
