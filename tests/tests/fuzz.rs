//! Bad input, fuzzed: every reader of user files is fed mutations of valid files (bit
//! flips, interesting bytes, cut, doubled and inserted runs, numbers made absurd, splices
//! of two files) and must answer with a value or an error that names the file, never a
//! panic.
//!
//! Each target runs `SMARTTEAMS_FUZZ_EXECS` inputs (default 1,500, a few seconds in all);
//! `SMARTTEAMS_FUZZ_EXECS=1000000 cargo test --profile ci -p tests --test fuzz -- --nocapture`
//! is the long run whose figures TESTING.md records. Inputs come from a fixed seed per
//! target, so a failure repeats; a panicking input is also saved under
//! `target/fuzz-crashes/`.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

fn execs() -> u64 {
    std::env::var("SMARTTEAMS_FUZZ_EXECS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_500)
}

/// Bytes a mutation likes to write: delimiters, signs, digits, extremes.
const INTERESTING: &[u8] = b"\x00\xff\x7f\x80\n\r \t\"'<>/=,.-+09eE[]:#@";
/// Numbers a mutation puts in place of one: huge, negative, not finite, empty.
const NUMBERS: &[&str] = &[
    "0",
    "-1",
    "4294967296",
    "18446744073709551616",
    "99999999999999999999",
    "1e308",
    "-1e308",
    "NaN",
    "inf",
    "",
    "0.0000001",
    "65536",
];

/// One to four random edits of `input` (or of a splice of it with `other`).
fn mutate(rng: &mut ChaCha8Rng, input: &[u8], other: &[u8]) -> Vec<u8> {
    let mut v = input.to_vec();
    for _ in 0..rng.random_range(1..=4) {
        let len = v.len();
        let at = if len == 0 { 0 } else { rng.random_range(0..len) };
        match rng.random_range(0..9) {
            0 if len > 0 => v[at] ^= 1 << rng.random_range(0..8),
            1 if len > 0 => v[at] = INTERESTING[rng.random_range(0..INTERESTING.len())],
            2 if len > 0 => {
                let end = (at + rng.random_range(1..=16)).min(len);
                v.drain(at..end);
            }
            3 if len > 0 => {
                let end = (at + rng.random_range(1..=64)).min(len);
                let run = v[at..end].to_vec();
                v.splice(at..at, run);
            }
            4 => {
                let bytes: Vec<u8> = (0..rng.random_range(1..=8)).map(|_| rng.random()).collect();
                v.splice(at..at, bytes);
            }
            5 => v.truncate(at),
            6 => {
                // A run of digits becomes an absurd number.
                if let Some(start) = (at..len).find(|&i| v[i].is_ascii_digit()) {
                    let end = (start..len).find(|&i| !v[i].is_ascii_digit()).unwrap_or(len);
                    let n = NUMBERS[rng.random_range(0..NUMBERS.len())];
                    v.splice(start..end, n.bytes());
                }
            }
            7 if !other.is_empty() => {
                let cut = rng.random_range(0..other.len());
                v.truncate(at);
                v.extend_from_slice(&other[cut..]);
            }
            _ => {
                if len > 0 {
                    v[at] = rng.random();
                }
            }
        }
    }
    v
}

/// What a target's reader said about one input.
enum Verdict {
    Accepted,
    Refused(String),
}

/// Feed `execs()` mutations of `seeds` to `read`; every error must mention `must_name`.
fn fuzz(target: &str, seeds: &[Vec<u8>], must_name: &str, mut read: impl FnMut(&[u8]) -> Verdict) {
    assert!(!seeds.is_empty(), "{target}: no seed inputs");
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(crc32(target.as_bytes())));
    let (mut accepted, mut refused) = (0u64, 0u64);
    let started = Instant::now();
    // The seeds themselves first: each must be accepted.
    for (i, s) in seeds.iter().enumerate() {
        if let Verdict::Refused(e) = read(s) {
            panic!("{target}: seed {i} is refused: {e}");
        }
    }
    for n in 0..execs() {
        let a = &seeds[rng.random_range(0..seeds.len())];
        let b = &seeds[rng.random_range(0..seeds.len())];
        let input = mutate(&mut rng, a, b);
        match catch_unwind(AssertUnwindSafe(|| read(&input))) {
            Ok(Verdict::Accepted) => accepted += 1,
            Ok(Verdict::Refused(e)) => {
                refused += 1;
                assert!(
                    e.contains(must_name),
                    "{target}: input {n}: the error does not name {must_name}: {e}"
                );
            }
            Err(_) => {
                let dir = workspace().join("target/fuzz-crashes");
                std::fs::create_dir_all(&dir).unwrap();
                let file = dir.join(format!("{target}-{n}.bin"));
                std::fs::write(&file, &input).unwrap();
                panic!("{target}: input {n} panicked the reader (saved to {})", file.display());
            }
        }
    }
    let secs = started.elapsed().as_secs_f64();
    println!(
        "fuzz {target}: {} inputs in {secs:.1} s ({:.0}/s): {accepted} accepted, {refused} refused, 0 panics",
        accepted + refused,
        (accepted + refused) as f64 / secs.max(1e-9)
    );
}

fn crc32(bytes: &[u8]) -> u32 {
    bytes
        .iter()
        .fold(0x811c_9dc5u32, |h, &b| (h ^ u32::from(b)).wrapping_mul(0x0100_0193))
}

fn verdict<T, E: std::fmt::Display>(r: Result<T, E>) -> Verdict {
    match r {
        Ok(_) => Verdict::Accepted,
        Err(e) => Verdict::Refused(format!("{e:#}")),
    }
}

#[test]
fn fuzz_map_file_reader() {
    let seeds: Vec<Vec<u8>> = ["demo", "caves", "maze", "rooms", "scene"]
        .iter()
        .map(|m| std::fs::read(workspace().join(format!("maps/{m}.stmap"))).unwrap())
        .collect();
    let path = Path::new("fuzzed.stmap");
    fuzz("map-file", &seeds, "fuzzed.stmap", |bytes| {
        verdict(sim_core::world::MapData::from_bytes(bytes, path))
    });
}

#[test]
fn fuzz_xml_config() {
    let dir = workspace().join("configs");
    let seeds: Vec<Vec<u8>> = ["demo.xml", "teams.xml", "bench-1000.xml"]
        .iter()
        .map(|c| std::fs::read(dir.join(c)).unwrap())
        .collect();
    let path = dir.join("fuzzed-config.xml");
    fuzz("xml-config", &seeds, "fuzzed-config.xml", |bytes| {
        verdict(sim_core::io::SimConfig::parse(&String::from_utf8_lossy(bytes), &path))
    });
}

#[test]
fn fuzz_sweep_file() {
    let dir = workspace().join("configs");
    let seeds = vec![
        std::fs::read(dir.join("sweep-demo.xml")).unwrap(),
        br#"<sweep config="demo.xml" rounds="5"><strategy group="scouts" values="frontier,cooperative"/><map values="../maps/demo.stmap,../maps/rooms.stmap"/><rounds values="1,2"/></sweep>"#.to_vec(),
    ];
    let path = dir.join("fuzzed-sweep.xml");
    fuzz("sweep-file", &seeds, "fuzzed-", |bytes| {
        verdict(sim_core::io::sweep::Sweep::parse(
            &String::from_utf8_lossy(bytes),
            &path,
        ))
    });
}

/// A file in a scratch folder that the importer reads; `fuzz` sees its bytes.
fn fuzz_import(target: &str, name: &str, seeds: &[Vec<u8>], extra: &[(&str, &[u8])]) {
    let dir = tempfile::tempdir().unwrap();
    for (file, bytes) in extra {
        std::fs::write(dir.path().join(file), bytes).unwrap();
    }
    let path = dir.path().join(name);
    let opts = editor::import::ImportOptions::default();
    fuzz(target, seeds, name, |bytes| {
        std::fs::write(&path, bytes).unwrap();
        verdict(editor::import::import(&path, &opts))
    });
}

/// A small obstacle picture in `format`.
fn picture(format: image::ImageFormat) -> Vec<u8> {
    let img = image::GrayImage::from_fn(24, 16, |x, y| {
        image::Luma([if (x / 4 + y / 4) % 3 == 0 { 0 } else { 255 }])
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, format).unwrap();
    out.into_inner()
}

#[test]
fn fuzz_image_import() {
    let seeds: Vec<Vec<u8>> = [
        image::ImageFormat::Png,
        image::ImageFormat::Pnm,
        image::ImageFormat::Bmp,
        image::ImageFormat::Jpeg,
    ]
    .into_iter()
    .map(picture)
    .collect();
    fuzz_import("image-import", "fuzzed.img", &seeds, &[]);
}

#[test]
fn fuzz_ros_import() {
    let yaml = b"image: map.pgm\nresolution: 0.050000\norigin: [-10.000000, -10.000000, 0.000000]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n".to_vec();
    let scaled = b"image: map.pgm\nmode: scale\nresolution: 0.1\norigin: [0.0, 2.5, 0.0]\nnegate: 1\noccupied_thresh: 0.9\nfree_thresh: 0.1\n".to_vec();
    let pgm = picture(image::ImageFormat::Pnm);
    fuzz_import(
        "ros-yaml-import",
        "fuzzed.yaml",
        &[yaml.clone(), scaled],
        &[("map.pgm", &pgm)],
    );
    // And the image beside a valid YAML: errors then name the image.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("map.yaml"), &yaml).unwrap();
    let image = dir.path().join("map.pgm");
    let opts = editor::import::ImportOptions::default();
    fuzz("ros-image-import", &[pgm], "map.pgm", |bytes| {
        std::fs::write(&image, bytes).unwrap();
        verdict(editor::import::import(&dir.path().join("map.yaml"), &opts))
    });
}

#[test]
fn fuzz_movingai_import() {
    let small = b"type octile\nheight 4\nwidth 6\nmap\n..@@..\n.T..S.\n......\nWW@...\n".to_vec();
    let crlf = b"type octile\r\nheight 2\r\nwidth 3\r\nmap\r\n.@.\r\nTGS\r\n".to_vec();
    fuzz_import("movingai-import", "fuzzed.map", &[small, crlf], &[]);
}

/// Checkpoints of a small cooperative run (known maps, sightings and messages in flight)
/// at two rounds. Half the mutations get their body length and checksum mended, so that
/// they reach the decoders and the checks of the state against the scenario instead of
/// stopping at the framing; every accepted one is restored into a simulation of the
/// scenario, which then plays three rounds from it.
#[test]
fn fuzz_checkpoint_reader() {
    use sim_core::io::{Checkpoint, RunSource, SimConfig, write_checkpoint};
    let dir = tempfile::tempdir().unwrap();
    let config_path = dir.path().join("fuzz.xml");
    std::fs::write(
        &config_path,
        format!(
            r#"<simulation name="fuzz" seed="5" rounds="40">
  <map file="{}"/>
  <group name="scouts" count="4" type="explorer" strategy="cooperative"/>
  <group name="walkers" count="2" type="explorer" strategy="random_walk"/>
</simulation>"#,
            workspace().join("maps/demo.stmap").display()
        ),
    )
    .unwrap();
    let config = SimConfig::load(&config_path).unwrap();
    let registry = sim_core::agent::StrategyRegistry::with_builtins();
    let source = RunSource::of(&config).unwrap();
    let file = dir.path().join("fuzzed.ckpt");
    let mut sim = sim_core::engine::Simulation::new(config.scenario(&registry).unwrap()).unwrap();
    let mut metrics = Vec::new();
    let mut seeds = Vec::new();
    for round in 1..=30 {
        metrics.push(sim.step().metrics);
        if round == 10 || round == 30 {
            write_checkpoint(&file, &source, 10, &metrics, &sim).unwrap();
            seeds.push(std::fs::read(&file).unwrap());
        }
    }
    let mut target = sim_core::engine::Simulation::new(config.scenario(&registry).unwrap()).unwrap();
    fuzz("checkpoint", &seeds, "fuzzed.ckpt", |bytes| {
        let mut bytes = bytes.to_vec();
        if bytes.len() % 2 == 0 && bytes.len() >= 40 {
            // Magic, format, version length and text, then the body length.
            let at = 22 + usize::from(u16::from_le_bytes([bytes[20], bytes[21]]));
            if let Some(body) = (bytes.len() - 4).checked_sub(at + 8) {
                bytes[at..at + 8].copy_from_slice(&(body as u64).to_le_bytes());
            }
            let end = bytes.len() - 4;
            let crc = crc32fast::hash(&bytes[..end]);
            bytes[end..].copy_from_slice(&crc.to_le_bytes());
        }
        let restored = Checkpoint::from_bytes(&bytes, &file).and_then(|c| c.restore(&mut target));
        if restored.is_ok() {
            // An accepted state must also play on: a few rounds of it, without a panic.
            for _ in 0..3 {
                target.step();
            }
        }
        verdict(restored)
    });
}
