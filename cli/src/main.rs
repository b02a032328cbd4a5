//! `itgfx`: information theory for computer graphics, from the command line.

use std::ffi::OsString;
use std::io::Write;
use std::process::ExitCode;

use itgfx_cli::args::Args;
use itgfx_cli::{CliError, complexity, devices, measure, viewpoints};

const USAGE: &str = "itgfx — information theory for computer graphics

Usage:
  itgfx complexity SCENE [OPTIONS]  scene visibility channel: H_P, H_S, I_S, I_S^c (itgfx complexity --help)
  itgfx measure NAME [OPTIONS]   evaluate an information measure (itgfx measure --help)
  itgfx viewpoints MESH [OPTIONS]   viewpoint channel: VE, VMI, best views (itgfx viewpoints --help)
  itgfx devices                  Vulkan devices found, and the one --backend vulkan uses
  itgfx --version

Every command accepts --json (one JSON object on stdout) and --base 2|e|10.
Errors are one line on stderr and exit code 2.";

const VIEWPOINTS_HELP: &str = "itgfx viewpoints MESH [OPTIONS] — the viewpoint channel V -> O (Part V)

MESH is an .obj file or a built-in (geosphere:L, torus:U,V, table-chairs:N, the regular
solids, ...; see itgfx complexity --help). The first surface a ray meets is what it sees.
Channel:
  --viewpoints N     12, 42 (default), 162, 642 or 2562 points of a subdivided icosahedron
  --resolution R     R x R rays per viewpoint over the cone around the object (default 128);
                     small polygons need more: aim for several rays per visible polygon
  --distance D       viewpoint distance in bounding-sphere radii (default 3)
  --uniform-input    p(V) uniform instead of the projected area
  --background       count the background as an extra polygon
Selection:
  --best-n N         at most N best views, greedy (default 6)
  --capture F        stop once the views capture F of I(V;O) (default 0.9)
  --explore S        steps of the guided exploration path from the best view (default 12)
Pictures (PNG renders, PLY with vertex colours; all written atomically):
  --out DIR          every picture below under its default name in DIR
  --best-image F, --worst-image F, --best-n-image F, --importance-image F
  --sphere-image F   the viewpoint sphere coloured by VMI (top) and VE (bottom), best view red
  --saliency-image F, --ao-image F, --info-image F, --export-ply F (AO), --saliency-ply F
  --smooth K         pictures average each polygon with its neighbours K times (default 2);
                     JSON values are never smoothed
Output: --json, --per-polygon (I(o;V), saliency and p(o) per polygon), --base 2|e|10,
        --backend cpu|vulkan|reference";

fn complexity_help() -> String {
    let mut s = String::from(
        "itgfx complexity SCENE [OPTIONS] — the scene visibility channel (Part III)\n\n\
         SCENE is an .obj file (one patch per polygon) or a built-in:\n",
    );
    for b in itgfx_backends::scene::BUILT_IN {
        s.push_str(&format!("  {}\n      {}\n", b.syntax, b.description));
    }
    s.push_str(
        "\nOptions:\n  --lines N        lines to cast (default 1e6; global lines that miss count)\n\
         \x20 --seed S         seed (default 1); same seed, same numbers, any thread count\n\
         \x20 --local          local lines from the patches instead of global lines\n\
         \x20 --subdivide K    split every patch into K x K cells\n\
         \x20 --blocks B       jackknife blocks for standard errors (default 8; 1 = none)\n\
         \x20 --backend cpu|reference|vulkan   (default cpu)\n\
         \x20 --export-ply F   mesh coloured by information per unit area (--color-by delta: by I_i^c - I_i)\n\
         \x20 --image F.png    the same, rendered from a default camera\n\
         \x20 --offset K       first line index (shards of one run: same seed, disjoint ranges)\n\
         \x20 --save-counts F  write the counts; --merge F1,F2,... evaluates saved shards together\n\
         \x20 --threads T      worker threads (default: all cores)\n\
         \x20 --base 2|e|10    --json\n",
    );
    s
}

/// One JSON object, or the readable table.
fn render(report: &itgfx_cli::report::Report, json: bool) -> String {
    if json { report.to_json().to_string() } else { report.to_table().trim_end().to_string() }
}

fn run(mut words: Vec<OsString>) -> Result<Option<String>, CliError> {
    if words.is_empty() {
        return Ok(Some(USAGE.to_string()));
    }
    let cmd = words.remove(0).into_string().map_err(|_| CliError::usage("command is not UTF-8"))?;
    match cmd.as_str() {
        "-h" | "--help" | "help" => Ok(Some(USAGE.to_string())),
        "-V" | "--version" => Ok(Some(format!("itgfx {}", env!("CARGO_PKG_VERSION")))),
        "measure" => {
            if words.is_empty() {
                return Ok(Some(measure::help()));
            }
            let name = words.remove(0).into_string().map_err(|_| CliError::usage("measure name is not UTF-8"))?;
            if name == "--help" || name == "-h" || name == "help" {
                return Ok(Some(measure::help()));
            }
            let args = Args::parse(words)?;
            if args.flag("help") {
                return Ok(Some(measure::help()));
            }
            let json = args.flag("json");
            let report = measure::run(&name, &args)?;
            Ok(Some(render(&report, json)))
        }
        "complexity" => {
            let args = Args::parse(words)?;
            if args.flag("help") {
                return Ok(Some(complexity_help()));
            }
            if let Some(t) = args.integer("threads")? {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(t.max(1) as usize)
                    .build_global()
                    .map_err(|e| CliError::usage(format!("--threads: {e}")))?;
            }
            let json = args.flag("json");
            let (report, _counts, _scene) = complexity::run(&args)?;
            args.finish()?;
            Ok(Some(render(&report, json)))
        }
        "viewpoints" => {
            let args = Args::parse(words)?;
            if args.flag("help") {
                return Ok(Some(VIEWPOINTS_HELP.to_string()));
            }
            let json = args.flag("json");
            let report = viewpoints::run(&args)?;
            args.finish()?;
            Ok(Some(render(&report, json)))
        }
        "devices" => {
            let args = Args::parse(words)?;
            let json = args.flag("json");
            let report = devices::run()?;
            args.finish()?;
            Ok(Some(render(&report, json)))
        }
        other => Err(CliError::usage(format!("unknown command {other:?}; try `itgfx --help`"))),
    }
}

fn main() -> ExitCode {
    let words: Vec<OsString> = std::env::args_os().skip(1).collect();
    match run(words) {
        Ok(Some(out)) => {
            let mut stdout = std::io::stdout().lock();
            // A closed pipe (e.g. `| head`) is not an error worth a panic.
            let _ = writeln!(stdout, "{out}");
            ExitCode::SUCCESS
        }
        Ok(None) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("itgfx: {e}");
            ExitCode::from(2)
        }
    }
}
