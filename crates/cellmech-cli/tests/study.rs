//! `cellmech study` end to end: a study killed with SIGKILL in the middle of a case and run
//! again gives the same results as an uninterrupted run, skipping the finished case; the
//! shards of a study together run every case once and collect into the same results;
//! bad studies are rejected before anything runs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cellmech-study-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn cellmech(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cellmech"))
        .args(args)
        .output()
        .unwrap()
}

/// A coarse (448 hex8) tension study with two cases: control and no microtubules.
const STUDY: &str = r#"
title = "coarse disruption"
base = "suspended-tension"
[set]
"cell.core_divisions" = 4
"cell.shell_layers" = 2
"cell.outer_layers" = 2
"protocol.elongation" = "2 um"
[[axis]]
kind = "disruption"
families = ["microtubule"]
"#;

/// study.csv without the wall-time column (the only one that may differ run to run).
fn results(out: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(out.join("study.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let wall = header.iter().position(|h| *h == "wall_time_s").unwrap();
    lines
        .map(|l| {
            l.split(',')
                .enumerate()
                .filter(|(i, _)| *i != wall)
                .map(|(_, f)| f.to_string())
                .collect()
        })
        .collect()
}

#[test]
fn a_study_killed_mid_case_resumes_and_matches_an_uninterrupted_run() {
    let dir = scratch("resume");
    let study = dir.join("study.toml");
    std::fs::write(&study, STUDY).unwrap();
    let study = study.to_str().unwrap();
    let interrupted = dir.join("interrupted");
    // Run, and kill the process (SIGKILL) while the second case is running.
    let mut child = Command::new(env!("CARGO_BIN_EXE_cellmech"))
        .args([
            "study",
            study,
            "--quiet",
            "--out",
            interrupted.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let first = interrupted.join("cases/control");
    let second = interrupted.join("cases/no-microtubule");
    let start = Instant::now();
    loop {
        if first.join("record.json").exists() && second.join("case.toml").exists() {
            child.kill().unwrap(); // SIGKILL on Unix
            break;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the study ended before it could be interrupted"
        );
        assert!(start.elapsed() < Duration::from_secs(300));
        std::thread::sleep(Duration::from_millis(5));
    }
    child.wait().unwrap();
    assert!(
        !second.join("record.json").exists(),
        "the second case was not interrupted"
    );
    // Rerun: the first case is skipped, the interrupted one redone.
    let o = cellmech(&[
        "study",
        study,
        "--json",
        "--out",
        interrupted.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["skipped"], 1, "{json}");
    assert_eq!(json["ran"], 1, "{json}");
    // An uninterrupted run gives the same results, digit for digit.
    let clean = dir.join("clean");
    let o = cellmech(&["study", study, "--quiet", "--out", clean.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(results(&interrupted), results(&clean));
    let rows = results(&clean);
    assert_eq!(rows.len(), 2);
    assert!(rows.iter().all(|r| r.contains(&"completed".to_string())));
    // Shards: two array tasks into their own folders, collected into a third.
    let (a, b, merged) = (dir.join("shard0"), dir.join("shard1"), dir.join("merged"));
    for (k, out) in [(0, &a), (1, &b)] {
        let shard = format!("{k}/2");
        let o = cellmech(&[
            "study",
            study,
            "--quiet",
            "--shard",
            &shard,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let count = |d: &Path| {
        ["control", "no-microtubule"]
            .iter()
            .filter(|c| d.join("cases").join(c).join("record.json").exists())
            .count()
    };
    assert_eq!(
        count(&a) + count(&b),
        2,
        "each case runs in exactly one shard"
    );
    let o = cellmech(&[
        "study",
        study,
        "--quiet",
        "--collect",
        "--from",
        a.to_str().unwrap(),
        "--from",
        b.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(results(&merged), results(&clean));
    // The documented Slurm array script: two tasks into one shared folder, then collect.
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../studies/slurm-array.sh");
    let shared = dir.join("slurm");
    for k in 0..2 {
        let o = Command::new("bash")
            .arg(&script)
            .args([study, shared.to_str().unwrap()])
            .env("CELLMECH", env!("CARGO_BIN_EXE_cellmech"))
            .env("SLURM_ARRAY_TASK_ID", k.to_string())
            .env("SLURM_ARRAY_TASK_COUNT", "2")
            .env("SLURM_CPUS_PER_TASK", "1")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let o = cellmech(&[
        "study",
        study,
        "--quiet",
        "--collect",
        "--out",
        shared.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(results(&shared), results(&clean));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The coarse study's modulus twin: control and the MTs at half their modulus.
fn modulus_study() -> String {
    STUDY.replace("coarse disruption", "coarse moduli").replace(
        "kind = \"disruption\"\nfamilies = [\"microtubule\"]",
        "kind = \"modulus\"\ncomponents = [\"microtubule\"]\nfactors = [0.5]",
    )
}

#[test]
fn several_studies_share_one_pool_and_their_common_control_runs_once() {
    let dir = scratch("pool");
    let (dis, modulus) = (dir.join("dis.toml"), dir.join("mod.toml"));
    std::fs::write(&dis, STUDY).unwrap();
    std::fs::write(&modulus, modulus_study()).unwrap();
    let (dis, modulus) = (dis.to_str().unwrap(), modulus.to_str().unwrap());
    let pooled = dir.join("pooled");
    let run = || {
        let o = cellmech(&[
            "study",
            modulus,
            dis,
            "--json",
            "--jobs",
            "2",
            "--out",
            pooled.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        json["studies"].as_array().unwrap().clone()
    };
    let studies = run();
    assert_eq!(studies.len(), 2);
    assert_eq!(studies[0]["shared"], 0, "{studies:?}");
    assert_eq!(studies[1]["shared"], 1, "{studies:?}");
    // The disruption study's control is a copy of the modulus study's (listed first), with
    // its own name, scenario file and provenance; the other cases ran in their folders.
    let record = |study: &str, case: &str| -> serde_json::Value {
        let path = pooled
            .join(study)
            .join("cases")
            .join(case)
            .join("record.json");
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    };
    let (source, copy) = (record("mod", "control"), record("dis", "control"));
    assert!(source["shared_from"].is_null());
    assert!(copy["shared_from"]
        .as_str()
        .unwrap()
        .ends_with("mod/cases/control"));
    for key in ["force_nn", "curve", "iterations", "factorizations", "seed"] {
        assert_eq!(source[key], copy[key], "{key}");
    }
    assert!(record("dis", "no-microtubule")["shared_from"].is_null());
    assert!(pooled.join("dis/cases/control/curve.csv").exists());
    let case_file = std::fs::read_to_string(pooled.join("dis/cases/control/case.toml")).unwrap();
    assert!(case_file.contains("coarse disruption"), "{case_file}");
    // The same results as the disruption study run on its own.
    let alone = dir.join("alone");
    let o = cellmech(&["study", dis, "--quiet", "--out", alone.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(results(&pooled.join("dis")), results(&alone));
    // A rerun skips every case.
    let again = run();
    for s in &again {
        assert_eq!(s["ran"], 0, "{again:?}");
    }
    // A case identical to a recorded one is copied, not run, even in a later invocation.
    std::fs::remove_dir_all(pooled.join("mod/cases/control")).unwrap();
    let again = run();
    assert_eq!(again[0]["ran"], 1, "{again:?}");
    let restored = record("mod", "control");
    assert!(restored["shared_from"]
        .as_str()
        .unwrap()
        .ends_with("dis/cases/control"));
    assert_eq!(restored["force_nn"], source["force_nn"]);
    // Two studies of the same name would write one folder.
    let o = cellmech(&["study", dis, dis, "--out", pooled.to_str().unwrap()]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("distinct names"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_misspelt_parameter_is_rejected_before_any_case_runs() {
    let dir = scratch("bad");
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        STUDY.replace(
            "[[axis]]\nkind = \"disruption\"\nfamilies = [\"microtubule\"]",
            "[[axis]]\nkind = \"grid\"\nparameter = \"cell.cytoplasm.shear_modulu\"\nvalues = [\"0.1 kPa\"]",
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let o = cellmech(&[
        "study",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("shear_modulu") && err.contains("shear_modulus"),
        "{err}"
    );
    assert!(!out
        .join("cases")
        .join("shear_modulu-0p1kPa")
        .join("record.json")
        .exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_built_in_studies_list_and_expand() {
    let o = cellmech(&["study", "--list"]);
    assert!(o.status.success());
    let list = String::from_utf8_lossy(&o.stdout);
    assert!(list.contains("suspended-tension-disruption"));
    let o = cellmech(&["study", "suspended-tension-disruption", "--dry-run"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cases: Vec<String> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter(|l| !l.starts_with(' '))
        .map(String::from)
        .collect();
    assert_eq!(
        cases,
        [
            "control",
            "no-actin",
            "no-microtubule",
            "no-intermediate",
            "no-actin-microtubule",
            "no-actin-intermediate",
            "no-microtubule-intermediate",
            "no-actin-microtubule-intermediate"
        ]
    );
    let o = cellmech(&["study", "suspended-tension-modulus", "--dry-run"]);
    let text = String::from_utf8_lossy(&o.stdout);
    // Continuum moduli are factors of the base's value, written with their unit.
    assert!(
        text.contains("cell.cytoplasm.shear_modulus = \"0.085 kPa\""),
        "{text}"
    );
    assert!(
        text.contains("families.microtubule.modulus_scale = 1.5"),
        "{text}"
    );
    assert_eq!(text.lines().filter(|l| !l.starts_with(' ')).count(), 13);
}

#[test]
fn the_large_tension_study_stretches_to_31_5_um_with_no_fa_in_the_grips() {
    let o = cellmech(&["study", "suspended-tension-large", "--dry-run"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let cases: Vec<&str> = text.lines().filter(|l| !l.starts_with(' ')).collect();
    assert_eq!(cases.len(), 12, "{text}");
    assert!(
        cases.contains(&"mt-embedded-prestressed.no-actin-microtubule"),
        "{text}"
    );
    assert!(text.contains("protocol.elongation = \"31.5 um\""), "{text}");
    assert!(
        text.contains("cell.fa_orientation = \"pentagon-on-axis\""),
        "{text}"
    );
}

#[test]
fn the_adherent_afm_studies_stop_at_1_um_with_their_named_subsets_and_components() {
    let o = cellmech(&["study", "--list"]);
    let list = String::from_utf8_lossy(&o.stdout);
    assert!(list.contains("adherent-afm-disruption"), "{list}");
    assert!(list.contains("adherent-afm-modulus"), "{list}");
    let o = cellmech(&["study", "adherent-afm-disruption", "--dry-run"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let cases: Vec<&str> = text.lines().filter(|l| !l.starts_with(' ')).collect();
    assert_eq!(
        cases,
        [
            "control",
            "no-cortex",
            "no-bundles",
            "no-microtubule",
            "no-intermediate",
            "no-cortex-bundles",
            "no-cortex-microtubule",
            "no-bundles-intermediate",
            "no-microtubule-intermediate",
            "no-bundles-microtubule-intermediate",
            "no-cortex-bundles-microtubule-intermediate"
        ]
    );
    // The force is compared at 1 um: every case's indentation ends there.
    assert_eq!(
        text.matches("protocol.depths = [\"0.5 um\", \"1 um\"]")
            .count(),
        11,
        "{text}"
    );
    assert!(text.contains("families.cortex.enabled = false"), "{text}");
    let o = cellmech(&["study", "adherent-afm-modulus", "--dry-run"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(text.lines().filter(|l| !l.starts_with(' ')).count(), 13);
    // The adherent cell's own parameters: its cytoplasm modulus (0.17 kPa) and its
    // cortex and bundle families.
    assert!(
        text.contains("cell.cytoplasm.shear_modulus = \"0.085 kPa\""),
        "{text}"
    );
    assert!(
        text.contains("families.cortex.modulus_scale = 0.5"),
        "{text}"
    );
    assert!(
        text.contains("families.bundles.modulus_scale = 1.5"),
        "{text}"
    );
}

#[test]
fn the_adherent_sites_study_pairs_each_site_with_its_own_control() {
    let o = cellmech(&["study", "--list"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("adherent-afm-sites"));
    let o = cellmech(&["study", "adherent-afm-sites", "--dry-run"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let cases: Vec<&str> = text.lines().filter(|l| !l.starts_with(' ')).collect();
    let mut expected = Vec::new();
    for site in ["apex", "receptor"] {
        for member in [
            "",
            ".no-bundles",
            ".no-microtubule",
            ".no-bundles-microtubule-intermediate",
        ] {
            expected.push(format!("site-{site}{member}"));
        }
    }
    assert_eq!(cases, expected);
    assert_eq!(
        text.matches("protocol.site = \"receptor\"").count(),
        4,
        "{text}"
    );
    assert_eq!(
        text.matches("protocol.contact = \"faces\"").count(),
        8,
        "{text}"
    );
}

#[test]
fn a_modulus_study_writes_its_tornado_chart() {
    let dir = scratch("tornado");
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        STUDY.replace(
            "[[axis]]\nkind = \"disruption\"\nfamilies = [\"microtubule\"]",
            "[[axis]]\nkind = \"modulus\"\ncomponents = [\"cytoplasm\", \"microtubule\"]\nfactors = [0.5, 1.5]",
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let o = cellmech(&[
        "study",
        study.to_str().unwrap(),
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let svg = std::fs::read_to_string(out.join("tornado.svg")).unwrap();
    assert!(svg.starts_with("<svg"));
    assert!(svg.contains("cytoplasm") && svg.contains("microtubule"));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("![tornado.svg](tornado.svg)"), "{md}");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("sensitivity"), "the chart is inlined");
    // The Sensitivity table: a row per component, the softer cytoplasm lowers the force
    // and the stiffer raises it.
    let row = |c: &str| -> Vec<f64> {
        md.lines()
            .find(|l| l.starts_with(&format!("| {c} |")))
            .unwrap_or_else(|| panic!("no row for {c}: {md}"))
            .split('|')
            .filter_map(|f| f.trim().parse().ok())
            .collect()
    };
    let cytoplasm = row("cytoplasm");
    assert_eq!(cytoplasm.len(), 3, "{md}");
    assert!(cytoplasm[0] < 0.0 && cytoplasm[1] > 0.0, "{cytoplasm:?}");
    assert_eq!(row("microtubule").len(), 3, "{md}");
    let _ = std::fs::remove_dir_all(&dir);
}
