//! The whole chain on scenes made by the project's own simulator: static talkers at several
//! azimuths, a jump, a circling talker, a fast one in a room, talkers who stop, noise only, a
//! 48 kHz PCM24 file, and an evaluation folder.

use cma_tests::{config_file, errors_after, host_sim, locate, make_scene, median, path_in};
use host_sim::io::ground_truth::{wrap180, Track};
use host_sim::localization::frame_estimates::CsvEstimate;
use std::path::{Path, PathBuf};

/// Signed errors (degrees) of the rows between `from_s` and `to_s` against the moving truth of
/// the scene `wav` (its `.pos.csv`).
fn errors_along_track(wav: &Path, rows: &[CsvEstimate], from_s: f64, to_s: f64) -> Vec<f64> {
    let track = Track::read(&wav.with_extension("pos.csv")).unwrap();
    rows.iter()
        .filter(|r| r.t_s > from_s && r.t_s < to_s)
        .map(|r| wrap180(r.azimuth_deg - track.azimuth_at(r.t_s)))
        .collect()
}

/// Of the frames between `from_s` and `to_s`: how many lie within 10° of the truth, and how many
/// there are.
fn within_10_deg(wav: &Path, rows: &[CsvEstimate], from_s: f64, to_s: f64) -> (usize, usize) {
    let errs = errors_along_track(wav, rows, from_s, to_s);
    (errs.iter().filter(|e| e.abs() <= 10.0).count(), errs.len())
}

/// A configuration file in `dir` with the grid tracker's motion fit switched off.
fn motion_fit_off(dir: &Path) -> String {
    config_file(dir, "off.toml", "[tracking.Grid]\nmotion_fit_pole = 0.0\n")
}

#[test]
fn static_talkers_are_found_at_several_azimuths() {
    let dir = tempfile::tempdir().unwrap();
    for (i, az) in [-150.0f64, -75.0, 0.0, 33.0, 100.0, 175.0]
        .iter()
        .enumerate()
    {
        let a = format!("{az}");
        let seed = format!("{}", i + 1);
        let wav = make_scene(
            dir.path(),
            &format!("s{i}.wav"),
            &[
                "--synth",
                "3",
                "--azimuth",
                &a,
                "--snr",
                "10",
                "--seed",
                &seed,
            ],
        );
        let rows = locate(&wav, &[]);
        let err = errors_after(&rows, 1.0, *az);
        let within = err.iter().filter(|e| **e <= 10.0).count() as f64 / err.len() as f64;
        assert!(
            within >= 0.95,
            "azimuth {az}: only {:.0} % within 10°",
            100.0 * within
        );
        assert!(
            median(&err) < 4.0,
            "azimuth {az}: median error {}",
            median(&err)
        );
    }
}

#[test]
fn thesis_preset_switches_and_baselines_also_localize() {
    let dir = tempfile::tempdir().unwrap();
    let wav = make_scene(
        dir.path(),
        "b.wav",
        &["--synth", "3", "--azimuth", "60", "--snr", "20"],
    );
    for flags in [
        &["--preset", "thesis"][..],
        &["--method", "fdiv"],
        &["--method", "tdiv"],
        &["--grid", "15"],
        &["--features", "magnitude"],
        &["--frame-onset", "off"],
        &["--features", "magnitude", "--frame-onset", "off"],
        &["--preset", "thesis", "--features", "active"],
        &["--preset", "thesis", "--frame-onset", "on"],
        &["--refine-curve", "distance1.5"],
        &["--refine-curve", "distance2"],
    ] {
        let rows = locate(&wav, flags);
        let err = errors_after(&rows, 1.5, 60.0);
        assert!(
            median(&err) < 8.0,
            "{flags:?}: median error {}",
            median(&err)
        );
    }
}

#[test]
fn a_jump_is_followed() {
    let dir = tempfile::tempdir().unwrap();
    let wav = make_scene(
        dir.path(),
        "j.wav",
        &["--synth", "5", "--track", "0:20,2.5:-120", "--snr", "15"],
    );
    let rows = locate(&wav, &[]);
    let before = errors_after(
        &rows
            .iter()
            .filter(|r| r.t_s < 2.5)
            .copied()
            .collect::<Vec<_>>(),
        1.0,
        20.0,
    );
    assert!(median(&before) < 5.0);
    let after = errors_after(&rows, 3.5, -120.0);
    assert!(
        median(&after) < 5.0,
        "after the jump: median error {}",
        median(&after)
    );
}

#[test]
fn a_circling_talker_is_followed_without_lag() {
    let dir = tempfile::tempdir().unwrap();
    let wav = make_scene(
        dir.path(),
        "m.wav",
        &[
            "--synth",
            "8",
            "--rotate",
            "30",
            "--start-azimuth",
            "-90",
            "--snr",
            "15",
        ],
    );
    let errs = errors_along_track(&wav, &locate(&wav, &[]), 2.0, 8.0);
    let bias = errs.iter().sum::<f64>() / errs.len() as f64;
    assert!(bias.abs() < 5.0, "mean error (lag) {bias}°");
    assert!(median(&errs.iter().map(|e| e.abs()).collect::<Vec<_>>()) < 6.0);
}

/// A talker circling from 30° in an office (5 × 4 × 3 m, RT60 0.4 s) 1.5 m away, 6 dB SNR:
/// `motion` gives his length and speed (scene flags), `seed` the rest.
fn circling_in_an_office(dir: &Path, name: &str, motion: &[&str], seed: &str) -> PathBuf {
    let mut args = motion.to_vec();
    args.extend_from_slice(&[
        "--start-azimuth",
        "30",
        "--room",
        "5x4x3:0.4",
        "--distance",
        "1.5",
        "--snr",
        "6",
        "--seed",
        seed,
    ]);
    make_scene(dir, name, &args)
}

/// Share of the frames from `from_s` to `to_s` within 10° of the truth, pooled over one
/// [`circling_in_an_office`] scene per seed (`NAME_PREFIX{seed}.wav`), located with the defaults.
fn share_circling_within_10_deg(
    name_prefix: &str,
    motion: &[&str],
    seeds: &[&str],
    from_s: f64,
    to_s: f64,
) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let (mut within, mut frames) = (0usize, 0usize);
    for seed in seeds {
        let name = format!("{name_prefix}{seed}.wav");
        let wav = circling_in_an_office(dir.path(), &name, motion, seed);
        let (n, all) = within_10_deg(&wav, &locate(&wav, &[]), from_s, to_s);
        within += n;
        frames += all;
    }
    within as f64 / frames as f64
}

/// A talker circling at 90°/s in an office (RT60 0.4 s, 6 dB) is heard only between his pauses;
/// the motion fit carries the track through them. Measured with this scene: 96.9 % of the frames
/// after the first second within 10° (MAE 4.70°), 75.8 % without the motion fit.
#[test]
fn a_fast_talker_is_followed_through_his_pauses() {
    let dir = tempfile::tempdir().unwrap();
    let wav = circling_in_an_office(
        dir.path(),
        "f.wav",
        &["--synth", "12", "--rotate", "90"],
        "2",
    );
    let within = |rows: &[CsvEstimate]| {
        let (n, all) = within_10_deg(&wav, rows, 1.0, 12.0);
        n as f64 / all as f64
    };
    let with_fit = within(&locate(&wav, &[]));
    let off = motion_fit_off(dir.path());
    let without_fit = within(&locate(&wav, &["--config", &off]));
    assert!(with_fit >= 0.85, "{:.1} % within 10°", 100.0 * with_fit);
    assert!(
        with_fit >= without_fit + 0.08,
        "{:.1} % with the motion fit, {:.1} % without",
        100.0 * with_fit,
        100.0 * without_fit
    );
}

/// Talkers who start circling at 90°/s in an office (RT60 0.4 s, 6 dB) as the scene starts: the
/// track trails them until the motion fit has the evidence for a slope. Measured with these eight
/// scenes: 58.4 % of the frames from 0.3 to 3 s within 10°, 52.3 % without the motion fit's early
/// slope (with the reliability scale `v_max` 0.003 before: 66.7 % and 56.2 %; the larger scale
/// trusts a single frame less, so a talker who sets off is followed later).
#[test]
fn a_talker_who_starts_walking_is_caught_up_soon() {
    let seeds = ["1", "2", "3", "4", "5", "6", "7", "8"];
    let motion = ["--synth", "3", "--rotate", "90"];
    let share = share_circling_within_10_deg("start", &motion, &seeds, 0.3, 3.0);
    assert!(
        share >= 0.55,
        "{:.1} % within 10° in the first seconds",
        100.0 * share
    );
}

/// Talkers who circle at 70°/s in an office (RT60 0.4 s, 6 dB) and stop after 4 s: the track must
/// not run on at the old speed through the pauses after the stop. Measured with these four
/// scenes: 73.3 % of the frames after the stop within 10°, 54.1 % before the motion fit learned to
/// see a stop between bursts of speech.
#[test]
fn a_talker_who_stops_is_not_carried_on() {
    let motion = ["--synth", "10", "--rotate", "70", "--rotate-until", "4"];
    let share = share_circling_within_10_deg("stop", &motion, &["1", "2", "3", "4"], 4.0, 10.0);
    assert!(
        share >= 0.65,
        "{:.1} % within 10° after the stop",
        100.0 * share
    );
}

/// Talkers who walk round the array at 12°/s (0.19° per frame, below the dead zone of the
/// tracker's plain velocity estimate) in an office (RT60 0.4 s, 6 dB): the motion fit's
/// significant slope drives the prediction however slow. Measured with these four scenes: 97.1 %
/// of the frames after the first second within 10°, 88.1 % without the motion fit (87.7 % when a
/// slope had to exceed 0.6° per frame to count).
#[test]
fn a_slow_walker_is_followed_without_lag() {
    let dir = tempfile::tempdir().unwrap();
    let off = motion_fit_off(dir.path());
    let (mut with_fit, mut without_fit, mut frames) = (0usize, 0usize, 0usize);
    for seed in ["1", "2", "3", "4"] {
        let wav = circling_in_an_office(
            dir.path(),
            &format!("slow{seed}.wav"),
            &["--synth", "12", "--rotate", "12"],
            seed,
        );
        let (n, all) = within_10_deg(&wav, &locate(&wav, &[]), 1.0, 12.0);
        with_fit += n;
        frames += all;
        without_fit += within_10_deg(&wav, &locate(&wav, &["--config", &off]), 1.0, 12.0).0;
    }
    let (with_fit, without_fit) = (
        with_fit as f64 / frames as f64,
        without_fit as f64 / frames as f64,
    );
    assert!(with_fit >= 0.93, "{:.1} % within 10°", 100.0 * with_fit);
    assert!(
        with_fit >= without_fit + 0.05,
        "{:.1} % with the motion fit, {:.1} % without",
        100.0 * with_fit,
        100.0 * without_fit
    );
}

#[test]
fn noise_only_gives_low_confidence_and_no_panic() {
    let dir = tempfile::tempdir().unwrap();
    // A talker 60 dB below the noise: effectively noise only.
    let wav = make_scene(
        dir.path(),
        "n.wav",
        &["--synth", "3", "--azimuth", "0", "--snr", "-60"],
    );
    let rows = locate(&wav, &[]);
    assert!(!rows.is_empty());
    let mean_conf = rows.iter().map(|r| r.confidence).sum::<f64>() / rows.len() as f64;
    let speech = make_scene(
        dir.path(),
        "s.wav",
        &["--synth", "3", "--azimuth", "0", "--snr", "20"],
    );
    let srows = locate(&speech, &[]);
    let speech_conf = srows.iter().map(|r| r.confidence).sum::<f64>() / srows.len() as f64;
    assert!(
        mean_conf < 0.5 * speech_conf,
        "noise confidence {mean_conf} vs speech {speech_conf}"
    );
}

#[test]
fn pcm24_48k_and_float_files_work() {
    let dir = tempfile::tempdir().unwrap();
    for fmt in ["pcm24", "float"] {
        let wav = make_scene(
            dir.path(),
            &format!("h{fmt}.wav"),
            &[
                "--synth",
                "3",
                "--azimuth",
                "-45",
                "--snr",
                "10",
                "--rate",
                "48000",
                "--format",
                fmt,
            ],
        );
        let rows = locate(&wav, &[]);
        // 48 kHz, brought to 16 kHz before the core: one estimate per 256 samples there.
        assert!(
            (rows.len() as f64 - 3.25 * 16000.0 / 256.0).abs() < 4.0,
            "{} rows",
            rows.len()
        );
        assert!(median(&errors_after(&rows, 1.0, -45.0)) < 4.0);
    }
}

#[test]
fn eval_scores_a_generated_folder() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = path_in(dir.path(), "manifest.csv");
    for (i, az) in ["10", "-100"].iter().enumerate() {
        let seed = format!("{}", i + 3);
        make_scene(
            dir.path(),
            &format!("e{i}.wav"),
            &[
                "--synth",
                "3",
                "--azimuth",
                az,
                "--snr",
                "10",
                "--seed",
                &seed,
                "--manifest",
                &manifest,
                "--set",
                "gen",
            ],
        );
    }
    let (report, scenes) = host_sim::evaluation::eval::evaluate(
        dir.path(),
        cma_core::LocatorConfig::default(),
        cma_core::ReferenceTable::ideal_5deg(),
        host_sim::io::wav_io::InputLayout::Cma1,
        2,
        &|_| {},
    )
    .unwrap();
    assert_eq!(scenes.len(), 2);
    assert_eq!(report.sets[0].set, "gen");
    assert!(
        report.overall.settled.acc_at(10) > 90.0,
        "{:?}",
        report.overall.settled
    );
    let plots = dir.path().join("plots");
    let p = plots.to_string_lossy().into_owned();
    host_sim(&[
        "eval",
        dir.path().to_str().unwrap(),
        "--json",
        "--plots",
        &p,
    ])
    .unwrap();
    assert!(plots.join("accuracy.png").exists() && plots.join("e0.png").exists());
}

#[test]
fn a_talker_in_a_shoebox_room_with_a_fan_is_found_and_the_fan_is_recorded() {
    let dir = tempfile::tempdir().unwrap();
    // A talker at -60° in a room, with one noise source.
    let scene = |name: &str, source: &str| {
        make_scene(
            dir.path(),
            name,
            &[
                "--synth",
                "8",
                "--azimuth",
                "-60",
                "--room",
                "6x5x3:0.4",
                "--distance",
                "1.5",
                "--snr",
                "20",
                "--noise-source",
                source,
                "--seed",
                "5",
            ],
        )
    };
    let wav = scene("fan.wav", "fan,az=70,el=20,dist=1.5,level=-18");
    let truth = std::fs::read_to_string(wav.with_extension("noise.csv")).unwrap();
    assert!(
        truth
            .lines()
            .nth(1)
            .unwrap()
            .starts_with("fan,70.00,20.00,1.50,-18.00,0.000,"),
        "{truth}"
    );
    let rows = locate(&wav, &[]);
    let err = errors_after(&rows, 1.0, -60.0);
    let within = err.iter().filter(|e| **e <= 10.0).count() as f64 / err.len() as f64;
    assert!(within >= 0.9, "only {:.0} % within 10°", 100.0 * within);
    // A white-noise loudspeaker 10 dB above the talker at the fan's place takes the estimate when
    // nothing takes its stationary excess off the peaks; the default takes it off and stays much
    // nearer the talker (measured: median error 130.3° without, 17.7° with).
    let loud = scene("loud.wav", "white,az=70,el=20,dist=1.5,level=10");
    let without_excess = config_file(
        dir.path(),
        "without-excess.toml",
        "[background]\nexcess_directivity = 1.0\n",
    );
    let loud_without = median(&errors_after(
        &locate(&loud, &["--config", &without_excess]),
        1.0,
        -60.0,
    ));
    assert!(
        loud_without > median(&err) + 20.0,
        "a loudspeaker 10 dB above the talker left the estimate at {loud_without} deg median error"
    );
    let loud_with = median(&errors_after(&locate(&loud, &[]), 1.0, -60.0));
    assert!(
        loud_with < loud_without - 60.0,
        "with the excess taken off {loud_with} deg, without {loud_without} deg"
    );
    // Bad source specifications are usage errors naming the flag.
    let bad = path_in(dir.path(), "bad.wav");
    let e = host_sim(&[
        "scene",
        "--out",
        &bad,
        "--synth",
        "2",
        "--noise-source",
        "drill,az=3",
    ])
    .unwrap_err()
    .to_string();
    assert!(e.contains("--noise-source"), "{e}");
}
