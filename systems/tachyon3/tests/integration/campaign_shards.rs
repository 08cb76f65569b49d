//! A campaign split into shards (as a batch scheduler's array jobs run it) and merged is
//! the campaign run in one go: the same rows, report and file, timing columns aside; and
//! what a merge refuses.

use cbfgen_tachyon3::sim::campaign::{self, table, CampaignSettings, CourseRanges, Report};

/// Short courses (one or two low steps) keep the test quick.
fn settings() -> CampaignSettings {
    let ranges = CourseRanges { rise: [0.05, 0.1], steps: [1, 2], start_gap: [0.1, 0.2], ..CourseRanges::default() };
    CampaignSettings { seed: 11, episodes: 7, first_id: 40, ranges, threads: Some(2), ..CampaignSettings::default() }
}

/// A CSV text without its timing columns: what two runs of the same episodes share.
fn without_timings(text: &str) -> Vec<Vec<String>> {
    let header: Vec<&str> = text.lines().next().expect("header").split(',').collect();
    let keep: Vec<usize> = (0..header.len()).filter(|&i| !table::TIMING_COLUMNS.contains(&header[i])).collect();
    text.lines()
        .map(|line| {
            let fields: Vec<&str> = line.split(',').collect();
            keep.iter().map(|&i| fields[i].to_string()).collect()
        })
        .collect()
}

/// A report's lines that do not depend on timing.
fn report_without_timings(report: &Report) -> Vec<String> {
    report
        .to_string()
        .lines()
        .filter(|l| !(l.contains("CPU") || l.contains("wall") || l.contains("µs")))
        .map(String::from)
        .collect()
}

#[test]
fn shards_merged_are_the_campaign_run_whole() {
    let whole = campaign::run(&settings(), |_| {}).expect("campaign");
    let whole_csv = campaign::output::csv(&whole);
    let mut texts = Vec::new();
    // Shards handed over out of order, as they finish.
    for index in [2, 0, 1] {
        let shard = settings().shard(index, 3).expect("shard");
        texts.push(table::csv(&campaign::run(&shard, |_| {}).expect("shard run").rows()));
    }
    let merged = table::merge(&texts).expect("merge");
    let ids: Vec<u64> = merged.iter().map(|r| r.id).collect();
    assert_eq!(ids, (40..47).collect::<Vec<_>>());
    assert!(table::gaps(&merged).is_empty());
    assert_eq!(without_timings(&table::csv(&merged)), without_timings(&whole_csv));
    assert_eq!(report_without_timings(&Report::of(&merged)), report_without_timings(&whole.report()));
    // Every episode's outcome and clearances as its record holds them, to the bit.
    for (row, record) in merged.iter().zip(&whole.records) {
        let s = record.result.as_ref().expect("summary");
        let r = row.result.as_ref().expect("summary");
        assert_eq!(row.outcome, record.outcome());
        assert_eq!(row.rise.to_bits(), record.episode.stairs.rise.to_bits());
        assert_eq!(r.min_body_clearance().to_bits(), s.min_body_clearance().to_bits());
        assert_eq!(r.min_toe_riser_clearance().to_bits(), s.min_toe_riser_clearance().to_bits());
        assert_eq!(r.min_h.map(f64::to_bits), s.min_h.map(f64::to_bits));
        assert_eq!(r.cycles, s.cycles);
    }
}

#[test]
fn shards_cover_every_id_once_in_blocks_of_near_equal_size() {
    for (episodes, count) in [(1, 1), (7, 3), (10, 10), (1000, 7), (999_999, 64)] {
        let all = CampaignSettings { episodes, first_id: 5, ..CampaignSettings::default() };
        let mut next = 5;
        for index in 0..count {
            let s = all.shard(index, count).expect("shard");
            assert_eq!(s.first_id, next, "{episodes} in {count}: shard {index} starts where the last ended");
            let size = s.episodes;
            assert!(size == episodes / count || size == episodes / count + 1, "{episodes}/{count}: {size}");
            assert_eq!((s.seed, s.ranges, s.body_cbf), (all.seed, all.ranges, all.body_cbf));
            next += size as u64;
        }
        assert_eq!(next, 5 + episodes as u64);
    }
    let all = CampaignSettings { episodes: 4, ..CampaignSettings::default() };
    assert!(all.shard(0, 0).is_err());
    assert!(all.shard(4, 4).is_err());
    assert!(all.shard(0, 5).is_err(), "more shards than episodes");
}

#[test]
fn a_merge_refuses_what_is_not_one_campaign() {
    let one = CampaignSettings { episodes: 2, ..settings() };
    let text = table::csv(&campaign::run(&one, |_| {}).expect("campaign").rows());
    let message = |texts: &[&str]| table::merge(texts).expect_err("refused").to_string();
    assert!(message(&[&text, &text]).contains("episode 40 is in two shards"));
    let other_seed =
        table::csv(&campaign::run(&CampaignSettings { seed: 12, ..one.clone() }, |_| {}).expect("run").rows());
    assert!(message(&[&text, &other_seed]).contains("seeds 11 and 12"));
    assert!(message(&[&text.replacen("id,seed", "id,sed", 1)]).contains("line 1"));
    let cut: String = text.lines().take(2).map(|l| format!("{}\n", &l[..l.len() / 2])).collect();
    let header = text.lines().next().expect("header");
    assert!(message(&[&format!("{header}\n{}", cut.lines().nth(1).expect("line"))]).contains("line 2"));
    assert!(message(&[header]).contains("no episode"));
    let garbled = text.replacen(",finished,", ",flying,", 1);
    assert!(message(&[&garbled]).contains("unknown outcome `flying`"));
}

#[test]
fn an_error_row_reads_back_with_its_message() {
    // The message may hold commas and quotes; only the error column is quoted.
    let one = CampaignSettings { episodes: 1, ..settings() };
    let mut rows = campaign::run(&one, |_| {}).expect("run").rows();
    rows[0].outcome = campaign::Outcome::Error;
    rows[0].result = Err("left the model's domain: x = 3, \"z\" = NaN".into());
    let back = table::parse(&table::csv(&rows)).expect("parse");
    assert_eq!(back, rows);
}
