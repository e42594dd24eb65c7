//! `host-sim scene`: synthesises a CMA1 scene (WAV + `.pos.csv`).

use crate::error::{Result, SimError};
use crate::flags::arg_values;
use crate::io::wav_io::OutFormat;
use crate::simulation::{array_model, noise_source, room, scene, signal};
use std::path::PathBuf;

/// `host-sim scene`.
#[derive(Debug, clap::Args)]
pub struct SceneArgs {
    /// Output WAV; the truth goes to the same name with `.pos.csv`.
    #[arg(long)]
    pub out: PathBuf,
    /// Talker: a mono WAV (resampled to --rate); with --synth, repeated to that length.
    #[arg(long)]
    pub source: Option<PathBuf>,
    /// Talker: a synthetic speech-like signal of this many seconds (at most 3600); with --source,
    /// the recording repeated to this length (a pause of 0.2–0.8 s before each repeat).
    #[arg(long, value_parser = arg_values::synth_seconds)]
    pub synth: Option<f64>,
    /// Output sample rate, Hz.
    #[arg(long, default_value_t = 16000)]
    pub rate: u32,
    /// Static talker azimuth, degrees.
    #[arg(long, value_parser = arg_values::degrees, conflicts_with_all = ["track", "rotate"])]
    pub azimuth: Option<f64>,
    /// Jumping talker: TIME:AZIMUTH pairs, e.g. `0:30,2:-160,4:95`.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "rotate")]
    pub track: Option<String>,
    /// Circling talker: angular speed in degrees per second (start from --start-azimuth).
    #[arg(long, value_parser = arg_values::degrees)]
    pub rotate: Option<f64>,
    /// With --rotate: the talker stops circling at this time (seconds) and stands still there.
    #[arg(long, value_parser = arg_values::scene_time)]
    pub rotate_until: Option<f64>,
    /// Start azimuth of --rotate, degrees.
    #[arg(long, value_parser = arg_values::degrees, default_value_t = 0.0)]
    pub start_azimuth: f64,
    /// Diffuse pink noise at this SNR on the omni, dB (omit for no noise).
    #[arg(long, value_parser = arg_values::decibels)]
    pub snr: Option<f64>,
    /// Measured first-order room response (AmbiX W, Y, Z, X), rotated to the talker azimuth.
    #[arg(long)]
    pub rir: Option<PathBuf>,
    /// A shoebox room by the image-source method, `LxWxH:RT60` in metres and seconds (e.g.
    /// `6x5x3:0.45`): the array placed from --seed at least 1 m from the walls, the talker at
    /// --distance (nearer where a wall is closer), each of its places with its own reflections
    /// (instead of a measured --rir).
    #[arg(long, conflicts_with = "rir")]
    pub room: Option<String>,
    /// Talker distance from the array in a --room, m.
    #[arg(long, value_parser = arg_values::talker_distance, default_value_t = 1.5, requires = "room")]
    pub distance: f64,
    /// A directional noise source (repeatable): `KIND[,az=DEG][,el=DEG][,dist=M][,level=DB][,on=S][,off=S]`,
    /// KIND one of fan, projector, vent, hum, white, babble, tilted; level relative to the talker on the
    /// omni (default −20 dB), rendered through the same room as the talker (--room, --rir or free
    /// field); e.g. `--noise-source fan,az=40,el=20,level=-18,on=40`. Written to NAME.noise.csv.
    #[arg(long = "noise-source", allow_hyphen_values = true)]
    pub noise_sources: Vec<String>,
    /// The room response is N3D rather than SN3D.
    #[arg(long)]
    pub rir_n3d: bool,
    /// Direct-sound azimuth of the room response, degrees (default: measured from its intensity).
    #[arg(long, value_parser = arg_values::degrees)]
    pub rir_direct: Option<f64>,
    /// Truncate the room response to this many seconds (at most 10).
    #[arg(long, value_parser = arg_values::rir_seconds, default_value_t = 1.0)]
    pub rir_length: f64,
    /// Noise-only lead-in before the talker, s (at most 600).
    #[arg(long, value_parser = arg_values::lead_in_seconds, default_value_t = 0.25)]
    pub lead_in: f64,
    /// Peak level of the file, dBFS.
    #[arg(long, value_parser = arg_values::decibels, default_value_t = -3.0)]
    pub peak_dbfs: f64,
    /// Noise / synthetic source seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Sample format of the WAV.
    #[arg(long, value_enum, default_value_t = OutFormat::Pcm16)]
    pub format: OutFormat,
    /// Append the scene to this manifest.csv (created if missing) under --set.
    #[arg(long)]
    pub manifest: Option<PathBuf>,
    /// Set name for --manifest.
    #[arg(long, default_value = "scenes")]
    pub set: String,
    /// Capsule imperfections of the simulated array.
    #[command(flatten)]
    pub array: array_model::ArrayArgs,
    /// Several talkers.
    #[command(flatten)]
    pub multi: crate::simulation::multi_talker_scene::MultiTalkerArgs,
}

/// Runs `host-sim scene`.
pub fn run(a: &SceneArgs) -> Result<()> {
    cma_core::decimator::Decimator::for_rate(a.rate).map_err(|source| SimError::Core {
        context: "--rate".into(),
        source,
    })?;
    if let Some(path) = &a.source {
        crate::io::wav_io::check_mono(path, "--source")?;
    }
    check_paths(a)?;
    if let Some(n) = a.multi.talkers {
        return crate::simulation::multi_talker_scene::run(a, n);
    }
    let source = scene::load_source(a.source.as_deref(), a.synth, a.rate, a.seed)?;
    if a.rotate_until.is_some() && a.rotate.is_none() {
        return Err(SimError::Usage(
            "--rotate-until stops a circling talker: give --rotate too".into(),
        ));
    }
    let motion = match (a.azimuth, &a.track, a.rotate) {
        (Some(az), None, None) => scene::Motion::Steps(vec![(0.0, az)]),
        (None, Some(t), None) => scene::Motion::parse_steps(t)?,
        (None, None, Some(speed)) => scene::Motion::Rotate {
            start_deg: a.start_azimuth,
            deg_per_s: speed,
            until_s: a.rotate_until,
        },
        (None, None, None) => scene::Motion::Steps(vec![(0.0, 0.0)]),
        _ => {
            return Err(SimError::Usage(
                "give at most one of --azimuth, --track, --rotate".into(),
            ))
        }
    };
    let noise_sources = a
        .noise_sources
        .iter()
        .map(|s| noise_source::NoiseSource::parse(s))
        .collect::<Result<Vec<_>>>()?;
    let (room, source_room) = rooms(a)?;
    let spec = scene::SceneSpec {
        source,
        rate: a.rate,
        lead_in_s: a.lead_in,
        motion,
        snr_db: a.snr,
        room,
        peak_dbfs: a.peak_dbfs,
        seed: a.seed,
        array: a.array.model()?,
        noise_sources,
        source_room,
    };
    let s = scene::synthesize(&spec);
    scene::write_scene(
        &s,
        &a.out,
        a.format,
        a.manifest.as_deref().map(|m| (m, a.set.as_str())),
    )?;
    write_noise_truth(&a.out, &spec.noise_sources)?;
    eprintln!("{}", scene::written_line(&s, &a.out, a.manifest.as_deref()));
    Ok(())
}

/// Refuses, before anything is rendered, outputs that would overwrite an input (`--source`,
/// `--rir`) or each other (`--out`, its truth files, `--manifest`), an output folder that does not
/// exist and a manifest of the other kind of scene.
fn check_paths(a: &SceneArgs) -> Result<()> {
    use crate::simulation::multi_talker_scene::{self as multi, MAX_TALKERS};
    let inputs: Vec<(&str, &std::path::Path)> = [("--source", &a.source), ("--rir", &a.rir)]
        .into_iter()
        .filter_map(|(flag, p)| p.as_deref().map(|p| (flag, p)))
        .collect();
    let mut truths = vec![
        a.out.with_extension("pos.csv"),
        a.out.with_extension("noise.csv"),
    ];
    truths.extend((0..usize::from(MAX_TALKERS)).map(|k| multi::truth_path(&a.out, k)));
    let mut outputs = vec![("--out", a.out.as_path())];
    outputs.extend(truths.iter().map(|p| ("truth file", p.as_path())));
    outputs.extend(a.manifest.as_deref().map(|m| ("--manifest", m)));
    crate::io::output_file::check_distinct(&inputs, &outputs)?;
    crate::io::output_file::check_folder(&a.out)?;
    if let Some(m) = &a.manifest {
        let (header, kind) = match a.multi.talkers {
            Some(_) => (multi::MANIFEST_HEADER, "multi-talker"),
            None => (scene::MANIFEST_HEADER, "single-talker"),
        };
        crate::io::manifest::check_appendable(m, header, kind)?;
    }
    Ok(())
}

/// The talker's room and the room of the noise sources: a shoebox (--room; the talker --distance
/// away at 1.2–1.7 m height, each place with its own response), a measured response (--rir,
/// rotated to the talker's azimuths) or free field.
pub(crate) fn rooms(
    a: &SceneArgs,
) -> Result<(Option<scene::TalkerRoom>, noise_source::SourceRoom)> {
    if let Some(spec) = &a.room {
        let shoebox = room::ShoeBox::parse(spec)?;
        let array = shoebox.array_position(a.seed);
        let height = 1.2 + 0.5 * signal::Rng::new(a.seed ^ 0x7461_6c6b).uniform();
        let elevation = ((height - array[2]) / a.distance)
            .clamp(-1.0, 1.0)
            .asin()
            .to_degrees();
        let length = a.rir_length.min(1.5 * shoebox.rt60).max(0.1);
        let talker = scene::TalkerRoom::ShoeBox(scene::ShoeBoxTalker {
            room: shoebox,
            array,
            elevation_deg: elevation,
            distance_m: a.distance,
            length_s: length,
            rate: a.rate,
        });
        let source_room = noise_source::SourceRoom::ShoeBox {
            room: shoebox,
            array,
            length_s: length,
        };
        return Ok((Some(talker), source_room));
    }
    let room = a
        .rir
        .as_deref()
        .map(|p| scene::RoomResponse::read(p, a.rate, a.rir_n3d, a.rir_length, a.rir_direct))
        .transpose()?;
    let source_room = match &room {
        Some(r) => noise_source::SourceRoom::Measured(r.clone()),
        None => noise_source::SourceRoom::Free,
    };
    Ok((room.map(scene::TalkerRoom::Rotated), source_room))
}

/// Header of a scene's noise-source truth (`NAME.noise.csv`).
const NOISE_TRUTH_HEADER: &str = "kind,azimuth_deg,elevation_deg,distance_m,level_db,on_s,off_s";

/// Writes the noise sources' truth next to the scene (`NAME.noise.csv`), when there are any;
/// without sources, removes one an earlier scene of the same name left.
pub(crate) fn write_noise_truth(
    out: &std::path::Path,
    sources: &[noise_source::NoiseSource],
) -> Result<()> {
    let path = out.with_extension("noise.csv");
    if sources.is_empty() {
        // A noise truth of an earlier scene of this name would describe sources this one has not.
        return crate::io::manifest::remove_stale(&path, NOISE_TRUTH_HEADER);
    }
    let mut text = format!("{NOISE_TRUTH_HEADER}\n");
    for s in sources {
        text.push_str(&s.truth_row());
        text.push('\n');
    }
    crate::io::wav_io::write_atomically(&path, |tmp| {
        std::fs::write(tmp, &text).map_err(|e| SimError::io(tmp, e))
    })
}
