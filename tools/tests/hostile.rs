//! Hostile input (issue 28, items 12–17): files and command lines a careless or malicious user gives
//! `shutter`. For each, the CLI must exit with one clear line on stderr (`error: …`, its key words
//! asserted), never panic or print a backtrace, write nothing on stdout, and leave every previous output
//! file and every node it was pointed at (a pipe, a device, a socket) as it was. Every case is cheap:
//! errors before any work, or a tiny CPU render.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// A fresh folder for this test process.
fn workdir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shutter-hostile-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn shutter() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_shutter"));
    c.env("SHUTTER_VALIDATION", "1").env("SHUTTER_PROGRESS", "off").env_remove("RUST_BACKTRACE");
    c
}

struct Outcome {
    code: i32,
    stdout: String,
    stderr: String,
}

fn run(mut c: Command) -> Outcome {
    let out = c.output().expect("run shutter");
    Outcome {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// A PNG of `w × h` pixels whose header says `claim_w × claim_h` (the CRC redone so the header reads).
fn png_claiming(dir: &Path, w: u32, h: u32, claim: (u32, u32)) -> PathBuf {
    let path = dir.join(format!("claims-{}x{}.png", claim.0, claim.1));
    let mut img = shutter::image::LinearImage::new(w, h);
    img.set(0, 0, [1.0, 0.0, 0.0, 1.0]);
    shutter::image_io::save_image(&path, &img).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    // Signature (8), IHDR length (4), "IHDR" (4), width (4), height (4), …, CRC over type and data.
    bytes[16..20].copy_from_slice(&claim.0.to_be_bytes());
    bytes[20..24].copy_from_slice(&claim.1.to_be_bytes());
    let crc = crc32(&bytes[12..29]);
    bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(&path, bytes).unwrap();
    path
}

fn crc32(data: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in data {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

const CAMERA: &str = "[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n";

/// One hostile input: the command, the exit code, and the key words of its one line.
struct Case {
    name: &'static str,
    args: Vec<String>,
    env: Vec<(&'static str, &'static str)>,
    code: i32,
    words: Vec<String>,
}

fn case(name: &'static str, args: &[&str], code: i32, words: &[&str]) -> Case {
    Case {
        name,
        args: args.iter().map(|s| s.to_string()).collect(),
        env: vec![],
        code,
        words: words.iter().map(|s| s.to_string()).collect(),
    }
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Checks one outcome against the rules of this file; returns a description of what broke.
fn check(c: &Case, o: &Outcome) -> Vec<String> {
    let mut bad = vec![];
    if o.code != c.code {
        bad.push(format!("exit code {} (want {})", o.code, c.code));
    }
    for word in ["panicked", "RUST_BACKTRACE", "stack backtrace", "\u{1b}"] {
        if o.stderr.contains(word) || o.stdout.contains(word) {
            bad.push(format!("output contains {word:?}"));
        }
    }
    if c.code == 1 {
        if o.stderr.lines().count() != 1 || !o.stderr.starts_with("error: ") {
            bad.push("stderr is not one `error:` line".into());
        }
        if !o.stdout.is_empty() {
            bad.push("partial output on stdout".into());
        }
        if o.stderr.len() > 600 {
            bad.push(format!("a {}-byte message", o.stderr.len()));
        }
    }
    // The key words are in the error line, or for a command that succeeds in its output.
    let (said, stream) = if c.code == 0 { (&o.stdout, "stdout") } else { (&o.stderr, "stderr") };
    for w in &c.words {
        if !said.contains(w.as_str()) {
            bad.push(format!("{stream} lacks {w:?}"));
        }
    }
    bad
}

/// Every hostile scene file and command line, in one table; each leaves the previous output file and
/// the folder's nodes as they were.
#[cfg(unix)]
#[test]
fn hostile_input_is_one_clear_line_and_destroys_nothing() {
    use std::os::unix::fs::FileTypeExt;
    let dir = workdir("table");
    let write = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    let with_object = |object: &str| format!("{CAMERA}[[object]]\n{object}\n");

    // A previous output, which no failing command may touch.
    let previous = dir.join("previous.exr");
    let mut img = shutter::image::LinearImage::new(3, 2);
    img.set(1, 1, [0.5, 0.25, 1.0, 1.0]);
    shutter::image_io::save_image(&previous, &img).unwrap();
    let previous_bytes = std::fs::read(&previous).unwrap();

    let missing_texture = write(
        "missing-texture.toml",
        &with_object("name = \"board\"\nmesh = \"box\"\n[object.material]\ntexture = \"stripe.png\""),
    );
    let escape_name = write(
        "escape.toml",
        &with_object("name = \"\\u001b[2J\\u001b[31mred\"\nmesh = \"box\"\n[object.material]\nroughness = 0"),
    );
    let escape_scene_name = write(
        "escape-scene-name.toml",
        &format!("name = \"\\u001b]0;pwned\\u0007\\u001b[2J\"\n{}", with_object("mesh = \"box\"")),
    );
    let raw_escape = write("raw-escape.toml", "name = \"\u{1b}[31m\"\n[camera\n");
    let key_time = write(
        "key-time.toml",
        &with_object(
            "mesh = \"box\"\n[object.transform_close]\ntranslate = [1, 0, 0]\n\
             [[object.transform_key]]\ntime = 0.99999999",
        ),
    );
    let tiny_bound = write(
        "tiny-bound.toml",
        &with_object(
            "mesh = \"box\"\n[[object.transform_key]]\ntime = 1e-45\n[[object.transform_key]]\ntime = 1e-46",
        ),
    );
    let huge = dir.join("huge.toml");
    std::fs::File::create(&huge).unwrap().set_len(1 << 30).unwrap(); // sparse: no disk used
    let long_line = write("long-line.toml", &format!("{CAMERA}name = [{}]\n", "7, ".repeat(300_000)));
    let not_utf8 = dir.join("latin1.toml");
    std::fs::write(&not_utf8, b"name = \"caf\xe9\"\n").unwrap();
    let big_texture = png_claiming(&dir, 2, 2, (20_000, 20_000));
    let texture_scene = write(
        "big-texture.toml",
        &with_object(&format!(
            "mesh = \"box\"\n[object.material]\ntexture = \"{}\"",
            big_texture.file_name().unwrap().to_str().unwrap()
        )),
    );
    let vfov = write("vfov.toml", &format!("{CAMERA}vfov_deg = 0\n"));
    let big_sphere = write("sphere.toml", &with_object("mesh = \"sphere\"\ndetail = 256"));
    let report = write("report.json", &format!("{{\"results\": \"{}\"}}", "A".repeat(1_000_000)));
    let socket = dir.join("socket.exr");
    let _listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();

    let previous_out = p(&previous);
    let mut cases = vec![
        case(
            "a missing texture names the scene file, the object and the key",
            &["reference", p(&missing_texture), "--size", "4x4", "--spp", "1", "--out", previous_out],
            1,
            &["missing-texture.toml", "object[0] (`board`).material.texture", "stripe.png", "No such file"],
        ),
        case(
            "an escape sequence in a name is printed escaped",
            &["reference", p(&escape_name), "--out", previous_out],
            1,
            &["\\u{1b}[2J\\u{1b}[31mred", "material.roughness: 0 is out of range"],
        ),
        case(
            "an escape sequence in the scene name is printed escaped",
            &["plan", p(&escape_scene_name), "--size", "8x4"],
            0,
            &["# plan of `\\u{1b}]0;pwned\\u{7}\\u{1b}[2J`"],
        ),
        case("a raw escape in a TOML error is escaped", &["plan", p(&raw_escape)], 1, &["\\u{1b}[31m"]),
        case(
            "a key time that rounds to 1 says so",
            &["plan", p(&key_time)],
            1,
            &["transform_key[0].time", "0.99999999 rounds to 1", "0.99999994"],
        ),
        case(
            "a tiny bound is printed short",
            &["plan", p(&tiny_bound)],
            1,
            &["transform_key[1].time", "in (1e-45, 1)"],
        ),
        case(
            "a 1 GiB scene file is refused unread",
            &["reference", p(&huge), "--out", previous_out],
            1,
            &["huge.toml", "1.00 GiB", "MAX_SCENE_FILE_BYTES"],
        ),
        case("a 1 MB line is quoted as a fragment", &["plan", p(&long_line)], 1, &["long-line.toml", "…`)"]),
        case("a scene file that is not UTF-8", &["plan", p(&not_utf8)], 1, &["latin1.toml", "not UTF-8"]),
        case(
            "a texture over the size limit says the size and the limit",
            &["plan", p(&texture_scene)],
            1,
            &["20000×20000", "16384×16384", "MAX_TEXTURE_DIMENSION", "material.texture"],
        ),
        case("vfov 0 in a file", &["plan", p(&vfov)], 1, &["camera.vfov_deg: 0 is out of range"]),
        case(
            "a scene over the memory limit is refused with the figure before any work",
            &["reference", p(&big_sphere), "--size", "4x4", "--spp", "1", "--out", previous_out],
            1,
            &["memory", "MiB", "SHUTTER_MEMORY_LIMIT"],
        ),
        case(
            "a GPU render over the memory limit is refused with the figure before any upload",
            &[
                "render",
                p(&big_sphere),
                "--technique",
                "stochastic",
                "--spp",
                "4",
                "--size",
                "8x8",
                "--out",
                previous_out,
            ],
            1,
            &["memory", "`stochastic`", "MiB", "SHUTTER_MEMORY_LIMIT"],
        ),
        case(
            "an output that is a socket is refused before any work",
            &["reference", "static", "--size", "4x4", "--spp", "1", "--out", p(&socket)],
            1,
            &["socket.exr", "it is a socket"],
        ),
        case(
            "a bench report quoting a 1 MB string is quoted as a fragment",
            &["bench-compare", "--old", p(&report), "--new", p(&report)],
            1,
            &["report.json", "as a bench report", "[…]"],
        ),
        case(
            "compare of a missing file",
            &["compare", p(&dir.join("no-such.exr")), previous_out],
            // Not compared (2), not a regression (1): what a gating script tells apart.
            2,
            &["no-such.exr", "No such file"],
        ),
    ];
    for c in cases.iter_mut().filter(|c| c.name.contains("memory limit")) {
        c.env.push(("SHUTTER_MEMORY_LIMIT", "16M"));
    }

    let mut failures = vec![];
    for c in &cases {
        let mut cmd = shutter();
        cmd.args(&c.args);
        for (k, v) in &c.env {
            cmd.env(k, v);
        }
        let o = run(cmd);
        let bad = check(c, &o);
        if !bad.is_empty() {
            // At most 400 characters of each (a hostile file's message was once 1 GB).
            let cut = |s: &str| s.chars().take(400).collect::<String>();
            failures.push(format!(
                "{}: {}\n  stderr: {:?}\n  stdout: {:?}",
                c.name,
                bad.join("; "),
                cut(&o.stderr),
                cut(&o.stdout)
            ));
        }
        if std::fs::read(&previous).unwrap() != previous_bytes {
            failures.push(format!("{}: the previous output was changed", c.name));
        }
    }
    if !std::fs::symlink_metadata(&socket).unwrap().file_type().is_socket() {
        failures.push("the socket was replaced".into());
    }
    let temps: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(temps.is_empty(), "temporary files left: {temps:?}");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// Item 12: a closed standard output (`shutter compare a b | head -1`) ends the command quietly, as
/// SIGPIPE ends a Unix tool (exit 141, nothing on stderr); a full one (`> /dev/full`) is one clear
/// line and exit 1. Before, both panicked with a backtrace hint.
#[cfg(unix)]
#[test]
fn a_closed_or_full_stdout_is_not_a_panic() {
    let dir = workdir("stdout");
    let a = dir.join("a.exr");
    let mut img = shutter::image::LinearImage::new(4, 4);
    img.set(1, 2, [0.3, 0.2, 0.1, 1.0]);
    shutter::image_io::save_image(&a, &img).unwrap();

    // A closed pipe: the read end dropped before the child writes.
    let mut child = shutter()
        .args(["compare", p(&a), p(&a)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run shutter");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(141), "{stderr}");
    assert!(stderr.is_empty(), "{stderr}");

    // A full device.
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
    if let Ok(full) = full {
        let out = shutter()
            .args(["compare", p(&a), p(&a)])
            .stdout(Stdio::from(full))
            .output()
            .expect("run shutter");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr, "error: cannot write to standard output: No space left on device (os error 28)\n");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Item 13: `--out` onto a named pipe, or through a link to a character device, writes into it; the
/// node stays (before, the atomic rename replaced it by a regular file — as root, `/dev/null` too).
#[cfg(unix)]
#[test]
fn out_onto_a_pipe_or_a_device_writes_through() {
    use std::os::unix::fs::FileTypeExt;
    let dir = workdir("nodes");
    let input = dir.join("in.png");
    shutter::image_io::save_image(&input, &shutter::image::LinearImage::new(3, 3)).unwrap();
    let fifo = dir.join("pipe.png");
    let made = Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success());
    if made {
        // The read end opened first, non-blocking (O_NONBLOCK): the writer finds a reader, nothing
        // waits, and the small image fits the pipe's buffer.
        let mut reader = {
            use std::os::unix::fs::OpenOptionsExt;
            std::fs::OpenOptions::new().read(true).custom_flags(0o4000).open(&fifo).unwrap()
        };
        let o = run({
            let mut c = shutter();
            c.args(["convert", p(&input), p(&fifo)]);
            c
        });
        assert!(
            std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo(),
            "the pipe was replaced by a regular file: {}",
            o.stderr
        );
        assert_eq!(o.code, 0, "{}", o.stderr);
        let mut got = vec![];
        let _ = std::io::Read::read_to_end(&mut reader, &mut got);
        assert!(got.starts_with(b"\x89PNG"), "the pipe's reader got {} bytes", got.len());
    }
    let null = dir.join("null.png");
    std::os::unix::fs::symlink("/dev/null", &null).unwrap();
    let o = run({
        let mut c = shutter();
        c.args(["convert", p(&input), p(&null)]);
        c
    });
    assert_eq!(o.code, 0, "{}", o.stderr);
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device(), "/dev/null was replaced");
    assert!(std::fs::symlink_metadata(&null).unwrap().file_type().is_symlink());
    let _ = std::fs::remove_dir_all(&dir);
}
