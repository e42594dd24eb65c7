//! A talker beside a directional noise source: `host-sim scene` renders a static talker and a
//! white-noise loudspeaker 10 dB below him in a room, on from the first sample, and the localizer
//! runs with the background's stationary excess taken off the peaks (the default) and without
//! (`[background] excess_directivity = 1`). Thresholds are the values measured when the test was
//! written, with margin.

use cma_tests::{errors_after, locate, make_scene, path_in};

#[test]
fn a_loudspeakers_stationary_excess_is_taken_off_the_talkers_peaks() {
    let dir = tempfile::tempdir().unwrap();
    let without = path_in(dir.path(), "without.toml");
    std::fs::write(&without, "[background]\nexcess_directivity = 1.0\n").unwrap();
    // Measured (MAE after 1 s, talker at 30°): source at −70°: 5.24° with, 10.91° without;
    // source at 120°: 7.02° with, 41.47° without.
    for source in ["-70", "120"] {
        let wav = make_scene(
            dir.path(),
            &format!("loudspeaker{source}.wav"),
            &[
                "--synth",
                "12",
                "--azimuth",
                "30",
                "--room",
                "6x5x3:0.45",
                "--distance",
                "1.5",
                "--snr",
                "30",
                "--seed",
                "4",
                "--noise-source",
                &format!("white,az={source},el=0,dist=2,level=-10"),
            ],
        );
        let mae = |extra: &[&str]| {
            let errs = errors_after(&locate(&wav, extra), 1.0, 30.0);
            errs.iter().sum::<f64>() / errs.len() as f64
        };
        let with = mae(&["-q"]);
        let off = mae(&["--config", &without, "-q"]);
        assert!(
            with < 8.5,
            "source at {source}°: {with:.2}° with the excess taken off"
        );
        assert!(
            off > with + 4.0,
            "source at {source}°: {off:.2}° without, {with:.2}° with"
        );
    }
}
