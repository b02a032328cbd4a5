//! Writes the labelled retrieval set of `itgfx shapes` (docs/SHAPES.md).
//!
//! ```text
//! cargo run --release -p itgfx-cli --example shapes_set -- OUT MESH_DIR [PER_CLASS] [SEED]
//! ```
//!
//! MESH_DIR holds the shared meshes (bunny, spot, fandisk, suzanne, teapot);
//! each base mesh over 6,000 triangles is first decimated by vertex
//! clustering to at most 5,000 (the bunny: 69k). Every class (the five meshes
//! and the five parametric families of `shapes::dataset::FAMILIES`) gets
//! PER_CLASS (default 10) rotated, scaled, translated, remeshed and (half of
//! them) noised members; even members are the tuning part, odd ones the
//! held-out part. Writes `OUT/<class>-<i>.obj`, `labels.csv` (every shape),
//! `labels-tuning.csv`, `labels-heldout.csv`, `tuning.txt` and `heldout.txt`
//! (one file a line, for `xargs`), and `how.csv` (what was done to each).

use std::fmt::Write as _;
use std::path::PathBuf;

use itgfx_backends::formats;
use itgfx_backends::obj::write_obj;
use itgfx_backends::shapes::dataset::{FAMILIES, Split, decimate, retrieval_set};

const MESHES: [(&str, &str); 5] = [
    ("bunny", "stanford-bunny.obj"),
    ("spot", "spot.obj"),
    ("fandisk", "fandisk.obj"),
    ("suzanne", "suzanne.obj"),
    ("teapot", "teapot.obj"),
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        return Err("usage: shapes_set OUT MESH_DIR [PER_CLASS] [SEED]".into());
    }
    let out = PathBuf::from(&args[0]);
    let dir = PathBuf::from(&args[1]);
    let per_class: usize = args.get(2).map_or(Ok(10), |s| s.parse())?;
    let seed: u64 = args.get(3).map_or(Ok(2026), |s| s.parse())?;
    let mut meshes = Vec::new();
    for (class, file) in MESHES {
        let s = formats::load(&dir.join(file))?;
        let s = if s.triangles.len() > 6000 { decimate(&s, 5000) } else { s };
        eprintln!("{class}: {} triangles", s.triangles.len());
        meshes.push((class.to_string(), s));
    }
    let set = retrieval_set(&meshes, &FAMILIES, per_class, seed);
    std::fs::create_dir_all(&out)?;
    let (mut all, mut tuning, mut held, mut tl, mut hl, mut how) =
        (String::new(), String::new(), String::new(), String::new(), String::new(), String::new());
    for it in &set {
        let path = out.join(format!("{}.obj", it.name));
        let mut f = std::io::BufWriter::new(std::fs::File::create(&path)?);
        write_obj(&it.scene, &mut f)?;
        let p = path.display();
        let row = format!("{p},{}\n", it.class);
        all += &row;
        let _ = writeln!(how, "{p},{},{},{}", it.class, it.scene.triangles.len(), it.how.replace(',', ";"));
        if it.split == Split::Tuning {
            tuning += &row;
            let _ = writeln!(tl, "{p}");
        } else {
            held += &row;
            let _ = writeln!(hl, "{p}");
        }
    }
    for (name, text) in [
        ("labels.csv", &all),
        ("labels-tuning.csv", &tuning),
        ("labels-heldout.csv", &held),
        ("tuning.txt", &tl),
        ("heldout.txt", &hl),
        ("how.csv", &how),
    ] {
        std::fs::write(out.join(name), text)?;
    }
    eprintln!("{} shapes in {}", set.len(), out.display());
    Ok(())
}
