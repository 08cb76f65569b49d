//! The built `cbfgen` binary: every number outside its documented range is refused before
//! any work, with exit status 2 and one line naming the flag and the range (the ranges
//! below are the ones `--help` and the README state, written out here by hand); `LO,HI`
//! ranges are accepted as documented; a file error names its path.

use std::process::{Command, Output};

fn cbfgen(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cbfgen")).args(args).output().expect("the binary runs")
}

#[test]
fn numbers_outside_their_documented_ranges_are_refused_naming_the_flag_and_range() {
    // (arguments, flag, range as the message states it)
    let cases: &[(&[&str], &str, &str)] = &[
        // The 32 TB allocation of issue 32, and the other end.
        (&["latency", "--cycles", "1000000000000"], "--cycles", "1..=1000000"),
        (&["latency", "--cycles", "0"], "--cycles", "1..=1000000"),
        (&["latency", "--speed", "nan"], "--speed", "[0, 2]"),
        (&["latency", "--gap", "11"], "--gap", "[0, 10]"),
        (&["latency", "--eps-abs", "0"], "--eps-abs", "[1e-12, 1000]"),
        (&["latency", "--eps-rel", "1e4"], "--eps-rel", "[1e-12, 1000]"),
        (&["latency", "--rho", "1e7"], "--rho", "[1e-6, 1e6]"),
        (&["latency", "--alpha", "2"], "--alpha", "[0.01, 1.99]"),
        (&["latency", "--dense-max-steps", "0"], "--dense-max-steps", "1..=10000"),
        (&["latency", "--check-termination", "10001"], "--check-termination", "1..=10000"),
        (&["latency", "--adaptive-rho-interval", "-1"], "--adaptive-rho-interval", "0..=10000"),
        // Issue 32's 100 000 threads (load average over 500), and none.
        (&["campaign", "--threads", "100000"], "--threads", "1..=1024"),
        (&["campaign", "--threads", "0"], "--threads", "1..=1024"),
        (&["campaign", "--episodes", "0"], "--episodes", "1..=1000000"),
        (&["campaign", "--episodes", "1000001"], "--episodes", "1..=1000000"),
        (&["campaign", "--seed", "-1"], "--seed", "0..=18446744073709551615"),
        (&["campaign", "--first-id", "18446744073709551615"], "--first-id", "0..=18446744073708551615"),
        (&["campaign", "--rise", "0.05,0.5"], "--rise", "(0, 0.3]"),
        (&["campaign", "--rise", "0.2,0.05"], "--rise", "(0, 0.3]"),
        (&["campaign", "--rise", "0.05"], "--rise", "(0, 0.3]"),
        (&["campaign", "--rise", "0,0.1"], "--rise", "(0, 0.3]"),
        (&["campaign", "--shard", "3/3"], "--shard", "0 <= I < N"),
        (&["campaign", "--shard", "1"], "--shard", "0 <= I < N"),
        (&["simulate", "--run", "0.1,0.3"], "--run", "(0.15, 10]"),
        (&["simulate", "--steps", "0,3"], "--steps", "1..=20"),
        (&["simulate", "--steps", "1,21"], "--steps", "1..=20"),
        (&["simulate", "--start-gap", "0.1,inf"], "--start-gap", "[0, 10]"),
        (&["simulate", "--speed", "0,0.3"], "--speed", "(0, 1]"),
        (&["simulate", "--csv-every", "0"], "--csv-every", "1..=1000000"),
        (&["simulate", "--episode", "-1"], "--episode", "0..=18446744073709551615"),
        (&["ssat", "--alpha", "0"], "--alpha", "[1e-6, 1e9]"),
        (&["ssat", "--clearance", "2"], "--clearance", "[-1, 1]"),
        (&["ssat", "--pitch", "-4"], "--pitch", "[-3.15, 3.15]"),
        (&["lip", "--steps", "0"], "--steps", "1..=10000"),
        (&["lip", "--delta", "-0.1"], "--delta", "[0, 2]"),
        (&["arm", "--csv-every", "0"], "--csv-every", "1..=1000000"),
        (&["perceive", "--seed", "1.5"], "--seed", "0..=18446744073709551615"),
    ];
    for (args, flag, range) in cases {
        let out = cbfgen(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        let first = stderr.lines().next().unwrap_or_default();
        assert!(first.starts_with("error: ") && first.contains(flag) && first.contains(range), "{args:?}: {stderr}");
        // Refused before any work: nothing printed, no other error line.
        assert!(out.stdout.is_empty(), "{args:?}");
        assert_eq!(stderr.lines().filter(|l| l.starts_with("error")).count(), 1, "{args:?}: {stderr}");
    }
}

/// Every numeric flag takes a value inside its range (each parsed value reaches the
/// command as the type it reads: a mismatch would panic in clap, not refuse).
#[test]
fn every_numeric_flag_accepts_a_value_in_its_range() {
    let dir = std::env::temp_dir().join(format!("cbfgen-cli-accept-{}", std::process::id()));
    let out_dir = dir.to_str().expect("utf-8");
    let runs: &[&[&str]] = &[
        &["ssat", "--clearance", "-0.01", "--pitch", "0.1", "--alpha", "150"],
        &[
            "latency",
            "--cycles",
            "3",
            "--speed",
            "0.2",
            "--gap",
            "0.5",
            "--backend",
            "dense",
            "--dense-max-steps",
            "50",
            "--eps-abs",
            "1e-6",
            "--eps-rel",
            "1e-6",
            "--rho",
            "0.1",
            "--alpha",
            "1.6",
            "--check-termination",
            "5",
            "--adaptive-rho-interval",
            "0",
        ],
        &["lip", "--steps", "3", "--out", out_dir],
        &[
            "simulate",
            "--episode",
            "2",
            "--seed",
            "5",
            "--rise",
            "0.05,0.06",
            "--run",
            "0.3,0.3",
            "--steps",
            "1,1",
            "--start-gap",
            "0.1,0.1",
            "--speed",
            "0.4,0.4",
            "--csv-every",
            "100",
            "--no-body-cbf",
            "--no-osqp-reference",
            "--out",
            out_dir,
        ],
    ];
    for args in runs {
        let out = cbfgen(args);
        assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    }
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn a_range_given_as_lo_comma_hi_reaches_the_campaign() {
    let dir = std::env::temp_dir().join(format!("cbfgen-cli-{}", std::process::id()));
    let out = cbfgen(&[
        "campaign",
        "--episodes",
        "1",
        "--seed",
        "9",
        "--first-id",
        "7",
        "--threads",
        "1",
        "--rise",
        "0.05,0.06",
        "--steps",
        "1,1",
        "--out",
        dir.to_str().expect("utf-8"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let csv = std::fs::read_to_string(dir.join("episodes.csv")).expect("episodes.csv");
    let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    let line: Vec<&str> = csv.lines().nth(1).expect("one episode").split(',').collect();
    let field = |name: &str| line[header.iter().position(|h| *h == name).expect(name)];
    let rise: f64 = field("rise").parse().expect("rise");
    assert!((0.05..=0.06).contains(&rise), "rise {rise}");
    assert_eq!(field("steps"), "1");
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn shards_run_as_array_jobs_merge_into_the_campaigns_files() {
    let dir = std::env::temp_dir().join(format!("cbfgen-cli-shards-{}", std::process::id()));
    let path = |name: &str| dir.join(name).to_str().expect("utf-8").to_string();
    let common = ["--episodes", "3", "--seed", "4", "--threads", "1", "--rise", "0.05,0.06", "--steps", "1,1"];
    let whole = cbfgen(&[&["campaign"][..], &common, &["--out", &path("whole")]].concat());
    assert!(whole.status.success(), "{}", String::from_utf8_lossy(&whole.stderr));
    let mut shards = Vec::new();
    for index in 0..2 {
        let (shard, out) = (format!("{index}/2"), path(&format!("shard{index}")));
        let run = cbfgen(&[&["campaign"][..], &common, &["--shard", &shard, "--out", &out]].concat());
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        // Shard 0 of 2 runs ids 0 (3 * 0 / 2 to 3 * 1 / 2 = 1); shard 1 ids 1 and 2.
        let expected = if index == 0 { "episodes 0 to 0" } else { "episodes 1 to 2" };
        assert!(String::from_utf8_lossy(&run.stdout).contains(expected), "{}", String::from_utf8_lossy(&run.stdout));
        shards.push(out);
    }
    let merged = cbfgen(&["merge", &shards[1], &format!("{}/episodes.csv", shards[0]), "--out", &path("merged")]);
    let stdout = String::from_utf8_lossy(&merged.stdout);
    assert!(merged.status.success(), "{}", String::from_utf8_lossy(&merged.stderr));
    assert!(stdout.contains("merged 2 shards: 3 episodes of seed 4, ids 0 to 2"), "{stdout}");
    let outcome = |name: &str| -> Vec<String> {
        // Every column up to the timings (id .. min_h_*): the episode's own outcome.
        let text = std::fs::read_to_string(dir.join(name).join("episodes.csv")).expect("episodes.csv");
        text.lines().map(|l| l.split(',').take(25).collect::<Vec<_>>().join(",")).collect()
    };
    assert_eq!(outcome("merged"), outcome("whole"));
    assert_eq!(outcome("whole").len(), 4);
    for file in ["report.txt", "campaign_outcome_map.svg"] {
        assert!(dir.join("merged").join(file).exists(), "{file}");
    }
    // The same shard twice is refused, naming the episode.
    let twice = cbfgen(&["merge", &shards[0], &shards[0], "--out", &path("twice")]);
    assert_eq!(twice.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&twice.stderr).contains("episode 0 is in two shards"));
    std::fs::remove_dir_all(&dir).expect("clean up");
}

#[test]
fn an_output_directory_that_cannot_be_made_is_named_before_any_work() {
    // A path under a regular file cannot be a directory, whoever runs the test (root too).
    let file = std::env::temp_dir().join(format!("cbfgen-cli-file-{}", std::process::id()));
    std::fs::write(&file, "not a directory").expect("write");
    let out_dir = file.join("out");
    for command in ["simulate", "campaign", "perceive", "lip", "multilayer", "arm"] {
        let out = cbfgen(&[command, "--out", out_dir.to_str().expect("utf-8")]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{command}: {stderr}");
        let first = stderr.lines().next().unwrap_or_default();
        assert!(first.starts_with("error: ") && first.contains(&*out_dir.to_string_lossy()), "{command}: {stderr}");
        assert!(out.stdout.is_empty(), "{command}: nothing ran");
    }
    std::fs::remove_file(&file).expect("clean up");
}
