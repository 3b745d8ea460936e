//! The campaign file, the plan and one case run, against hand-worked expectations and the
//! navigation judge run directly.

use fusion_campaign::case::{run, sequence_config};
use fusion_campaign::file::CampaignFile;
use fusion_campaign::plan::{Case, fingerprint, plan};
use std::collections::BTreeMap;

const BASE: &str = r#"
name = "t"
seed = 11
replicas = 3
frames = 6
vis_size = 96
sources = ["vis", "tir"]
[axes]
trajectory = ["flyaround", "approach"]
sun_phase = [0, 90, 180]
earth = [false, true]
"#;

fn parse(text: &str) -> anyhow::Result<CampaignFile> {
    CampaignFile::parse(text, "c.toml")
}

fn by_id(cases: &[Case]) -> BTreeMap<String, Case> {
    cases.iter().map(|c| (c.id.clone(), Case { index: 0, ..c.clone() })).collect()
}

#[test]
fn the_plan_is_the_product_of_the_axes_with_stable_distinct_ids() {
    let cases = plan(&parse(BASE).unwrap()).unwrap();
    assert_eq!(cases.len(), 2 * 3 * 2 * 3);
    assert!(cases.iter().enumerate().all(|(i, c)| c.index == i));
    assert!(cases.iter().all(|c| c.id.len() == 16 && c.id.chars().all(|ch| ch.is_ascii_hexdigit())));
    let ids: std::collections::BTreeSet<&str> = cases.iter().map(|c| c.id.as_str()).collect();
    assert_eq!(ids.len(), cases.len());
    // Each combination once, each replica with its own sensor seed.
    let mut combos = std::collections::BTreeSet::new();
    for c in &cases {
        let key = (
            c.trajectory.as_str(),
            c.sun_phase_deg.map(f64::to_bits),
            c.earth_km.map(f64::to_bits),
            c.replica,
        );
        assert!(combos.insert(key));
    }
    let seeds: std::collections::BTreeSet<u64> = cases.iter().map(|c| c.seed).collect();
    assert_eq!(seeds.len(), cases.len());
    assert!(cases.iter().all(|c| c.seed < 1 << 31));
    // The baselines are always judged.
    assert_eq!(cases[0].sources, ["zero-motion", "oracle", "vis", "tir"]);
    // The same parameters listed in another order: the same cases under the same ids.
    let shuffled = BASE
        .replace(r#"["flyaround", "approach"]"#, r#"["approach", "flyaround"]"#)
        .replace("[0, 90, 180]", "[180, 0, 90]")
        .replace("[false, true]", "[true, false]");
    let other = plan(&parse(&shuffled).unwrap()).unwrap();
    assert_eq!(by_id(&other), by_id(&cases));
    assert_ne!(fingerprint("t", &other), fingerprint("t", &cases), "the order is part of the plan");
    // Another campaign seed: every id and seed moves.
    let reseeded = plan(&parse(&BASE.replace("seed = 11", "seed = 12")).unwrap()).unwrap();
    assert!(reseeded.iter().zip(&cases).all(|(a, b)| a.id != b.id && a.seed != b.seed));
    // Another frame count is another case.
    let longer = plan(&parse(&BASE.replace("frames = 6", "frames = 7")).unwrap()).unwrap();
    assert!(longer.iter().zip(&cases).all(|(a, b)| a.id != b.id));
}

#[test]
fn steps_and_uniform_draws() {
    let steps = parse(&BASE.replace("[0, 90, 180]", "{ from = 0, to = 180, steps = 7 }")).unwrap();
    let cases = plan(&steps).unwrap();
    let mut phases: Vec<f64> = cases.iter().filter_map(|c| c.sun_phase_deg).collect();
    phases.sort_by(f64::total_cmp);
    phases.dedup();
    assert_eq!(phases, [0.0, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0]);

    let uniform = parse(&BASE.replace("[0, 90, 180]", "{ uniform = [20, 40] }")).unwrap();
    let a = plan(&uniform).unwrap();
    let b = plan(&uniform).unwrap();
    assert_eq!(a, b, "a rerun draws the same values");
    assert_eq!(a.len(), 2 * 2 * 3);
    let drawn: Vec<f64> = a.iter().map(|c| c.sun_phase_deg.unwrap()).collect();
    assert!(drawn.iter().all(|p| (20.0..=40.0).contains(p)));
    let distinct: std::collections::BTreeSet<u64> = drawn.iter().map(|p| p.to_bits()).collect();
    assert_eq!(distinct.len(), drawn.len(), "each case draws its own value");
    // Without the axis: each sequence's own sun.
    let own = plan(&parse(&BASE.replace("sun_phase = [0, 90, 180]\n", "")).unwrap()).unwrap();
    assert!(own.iter().all(|c| c.sun_phase_deg.is_none()));
}

#[test]
fn bad_files_are_refused_in_one_line_naming_the_key() {
    let cases = [
        (BASE.replace("replicas = 3", "replicas = 3\nreplica = 2"), "unknown field `replica`"),
        (BASE.replace(r#""approach"]"#, r#""approch"]"#), "approch"),
        (BASE.replace("[0, 90, 180]", "[0, 90, 190]"), "axes.sun_phase: 190° is outside 0–180°"),
        (BASE.replace("[0, 90, 180]", "[0, 90, 90]"), "axes.sun_phase: the value"),
        (BASE.replace("[0, 90, 180]", "{ from = 0, to = 180, steps = 1 }"), "steps must be at least 2"),
        (BASE.replace("[0, 90, 180]", "{ uniform = [40, 20] }"), "lo < hi"),
        (BASE.replace("frames = 6", "frames = 1"), "frames must be at least 2"),
        (BASE.replace("vis_size = 96", "vis_size = 97"), "vis_size must be even"),
        (BASE.replace(r#"["vis", "tir"]"#, r#"["vis", "thermal"]"#), "unknown source 'thermal'"),
        (BASE.replace("[false, true]", "[false, 50]"), "axes.earth: an altitude of 50 km"),
        (BASE.replace("name = \"t\"", "name = \"a b\""), "name: letters"),
        (BASE.replace("replicas = 3", "replicas = 0"), "replicas must be at least 1"),
        (BASE.replace("seed = 11\n", ""), "missing field `seed`"),
        (format!("{BASE}\n[record]\nphases = [\"dusk\"]\n"), "unknown phase 'dusk'"),
    ];
    for (text, want) in cases {
        let e = format!("{:#}", parse(&text).expect_err(want));
        assert!(e.contains(want), "{e:?} lacks {want:?}");
        assert!(!e.contains('\n'), "not one line: {e:?}");
        assert!(e.starts_with("c.toml"), "names the file: {e:?}");
    }
}

#[test]
fn a_case_renders_what_it_names() {
    let file = parse(&BASE.replace(r#"["flyaround", "approach"]"#, r#"["radial", "flyaround"]"#)).unwrap();
    for c in plan(&file).unwrap() {
        let cfg = sequence_config(&c);
        assert_eq!(
            (cfg.name, cfg.frames, cfg.vis_size, cfg.tir_size, cfg.seed),
            (c.trajectory, 6, 96, 48, c.seed)
        );
        assert_eq!(cfg.sun_phase_deg, c.sun_phase_deg);
        let km = cfg.earth.map(|e| e.altitude_m / 1000.0);
        match (c.trajectory.as_str(), c.earth_km) {
            // `radial` is made for the Earth: it keeps its own when the case asks for none.
            ("radial", None) => assert_eq!(km, Some(500.0)),
            _ => assert_eq!(km, c.earth_km),
        }
    }
}

#[test]
fn a_case_run_gives_the_judges_figures_per_stream_and_phase() {
    let file = parse(
        r#"
        name = "one"
        seed = 3
        frames = 8
        vis_size = 96
        sources = ["vis"]
        [axes]
        trajectory = ["flyaround"]
        sun_phase = [45]
        [record]
        phases = ["all", "light"]
        "#,
    )
    .unwrap();
    let case = plan(&file).unwrap().remove(0);
    let scratch = tempfile::tempdir().unwrap();
    let rows = run(&case, scratch.path()).unwrap();
    // The scratch folder is emptied.
    assert_eq!(std::fs::read_dir(scratch.path()).unwrap().count(), 0);
    let keys: Vec<(String, String)> = rows.iter().map(|r| (r.source.clone(), r.phase.clone())).collect();
    let want: Vec<(String, String)> = ["oracle", "vis", "zero-motion"]
        .iter()
        .flat_map(|s| ["all", "light"].map(|p| (s.to_string(), p.to_string())))
        .collect();
    assert_eq!(keys, want);
    // The same sequence rendered and judged directly.
    let dir = tempfile::tempdir().unwrap();
    render_host::sequence::render_sequence(&sequence_config(&case), dir.path(), false).unwrap();
    let frames = fusion_navbench::bench::run_sequence(
        dir.path(),
        None,
        Some(&case.sources),
        false,
        fusion_navbench::registration::Registration::default(),
    )
    .unwrap();
    let direct = fusion_navbench::bench::summary(&frames);
    for r in &rows {
        assert_eq!(
            (r.case_id.as_str(), r.seed, r.trajectory.as_str()),
            (case.id.as_str(), case.seed, "flyaround")
        );
        assert_eq!(r.sun_phase_deg, Some(45.0));
        assert!(!r.earth && r.earth_km.is_none());
        assert_eq!(r.figures, direct.by_sequence["flyaround"][&r.source][&r.phase]);
    }
    // The oracle holds navigation, the zero-motion guess does not.
    let avail =
        |s: &str| rows.iter().find(|r| r.source == s && r.phase == "all").unwrap().figures.availability;
    assert!(
        avail("oracle") > 0.9 && avail("zero-motion") < 0.5,
        "{} {}",
        avail("oracle"),
        avail("zero-motion")
    );
}

#[test]
fn a_file_without_sources_judges_every_default_stream_raw_sensor_ones_too() {
    let file = parse(
        r#"
        name = "every"
        seed = 5
        frames = 4
        vis_size = 64
        [axes]
        trajectory = ["flyaround"]
        "#,
    )
    .unwrap();
    let case = plan(&file).unwrap().remove(0);
    let defaults: Vec<String> =
        fusion_navbench::bench::selected(None).unwrap().into_iter().map(|(n, _)| n).collect();
    assert_eq!(case.sources, defaults);
    assert!(
        sequence_config(&case).focal_plane.is_some(),
        "tir-raw is a default: the raw counts are rendered"
    );
    let named = plan(&parse(BASE).unwrap()).unwrap().remove(0);
    assert!(sequence_config(&named).focal_plane.is_none(), "vis, tir: no raw counts");
    let scratch = tempfile::tempdir().unwrap();
    let rows = run(&case, scratch.path()).unwrap();
    let judged: std::collections::BTreeSet<&str> = rows.iter().map(|r| r.source.as_str()).collect();
    let want: std::collections::BTreeSet<&str> = defaults.iter().map(|s| s.as_str()).collect();
    assert_eq!(judged, want);
}
