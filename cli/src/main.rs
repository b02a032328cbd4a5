//! `itgfx`: information theory for computer graphics, from the command line.

use std::io::Write;
use std::process::ExitCode;

use clap::error::ErrorKind;
use itgfx_cli::commands::{phantom, register, segment};
use itgfx_cli::options::{Cli, Command};
use itgfx_cli::{CliError, complexity, devices, measure, simplify, viewpoints, volume};

/// The system allocator, large blocks faulted in as transparent huge pages
/// ([`itgfx_cli::huge_pages`]).
#[global_allocator]
static ALLOCATOR: itgfx_cli::huge_pages::HugePages = itgfx_cli::huge_pages::HugePages;

/// One JSON object, or the readable table.
fn render(report: &itgfx_cli::report::Report, json: bool) -> String {
    if json { report.to_json().to_string() } else { report.to_table().trim_end().to_string() }
}

fn threads(t: Option<usize>) -> Result<(), CliError> {
    if let Some(t) = t {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .map_err(|e| CliError::usage(format!("--threads: {e}")))?;
    }
    Ok(())
}

fn run(cli: Cli) -> Result<String, CliError> {
    match cli.command {
        Command::Measure(m) => {
            let json = m.measure.common().json;
            Ok(render(&measure::run(&m.measure)?, json))
        }
        Command::Complexity(o) => {
            threads(o.run.tracing.threads)?;
            let (report, _counts, _scene) = complexity::run(&o)?;
            Ok(render(&report, o.run.common.json))
        }
        Command::Viewpoints(o) => {
            threads(o.tracing.threads)?;
            Ok(render(&viewpoints::run(&o)?, o.common.json))
        }
        Command::Simplify(o) => {
            threads(o.run.tracing.threads)?;
            Ok(render(&simplify::run(&o)?, o.run.common.json))
        }
        Command::Volume(o) => {
            threads(o.threads)?;
            Ok(render(&volume::run(&o)?, o.common.json))
        }
        Command::Devices(c) => Ok(render(&devices::run()?, c.json)),
        Command::Phantom(o) => Ok(render(&phantom::run_phantom(&o)?, o.json)),
        Command::Register(o) => Ok(render(&register::run_register(&o)?, o.common.json)),
        Command::Segment(o) => Ok(render(&segment::run_segment(&o)?, o.common.json)),
        Command::Render(o) => {
            threads(o.run.tracing.threads)?;
            Ok(render(&itgfx_cli::render::run(&o)?, o.run.common.json))
        }
        Command::Compare(o) => Ok(render(&itgfx_cli::render::run_compare(&o)?, o.common.json)),
        Command::Shapes(o) => {
            threads(o.tracing.threads)?;
            Ok(render(&itgfx_cli::commands::shapes::run::run(&o)?, o.common.json))
        }
        Command::Radiosity(o) => {
            threads(o.run.tracing.threads)?;
            Ok(render(&itgfx_cli::radiosity::run(&o)?, o.run.common.json))
        }
    }
}

/// Every error is one line: control characters (a newline in a path) are
/// escaped as a last resort, though messages quote paths already.
fn one_line(s: &str) -> String {
    s.trim_end().chars().flat_map(|c| if c.is_control() { c.escape_default().collect() } else { vec![c] }).collect()
}

/// Writes `text` and a newline to stdout. A closed pipe (`| head`) is not
/// an error: the reader wanted no more (as ripgrep does, exit quietly).
fn print(text: &str) -> Result<(), CliError> {
    let mut stdout = std::io::stdout().lock();
    match writeln!(stdout, "{text}").and_then(|()| stdout.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(CliError::runtime(format!("standard output: {e}"))),
        _ => Ok(()),
    }
}

fn fail(e: &CliError) -> ExitCode {
    eprintln!("itgfx: {}", one_line(&e.to_string()));
    ExitCode::from(e.exit_code())
}

fn main() -> ExitCode {
    let words: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let cli = match Cli::parse_words(&words) {
        Ok(cli) => cli,
        Err(e) => {
            return match e.kind() {
                ErrorKind::DisplayHelp
                | ErrorKind::DisplayVersion
                | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
                    // Help and version go to stdout with exit 0.
                    match print(e.render().to_string().trim_end()) {
                        Ok(()) => ExitCode::SUCCESS,
                        Err(e) => fail(&e),
                    }
                }
                _ => {
                    let measure = words.get(1).is_some_and(|w| w == "measure");
                    eprintln!("itgfx: {}", one_line(&itgfx_cli::clap_error::message(&e, measure)));
                    ExitCode::from(2)
                }
            };
        }
    };
    // Every output file of the run lands at the end, all or none.
    itgfx_cli::output::begin();
    match run(cli) {
        Ok(out) => match itgfx_cli::output::commit(|| print(&out)) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => fail(&e),
        },
        Err(e) => {
            itgfx_cli::output::abort();
            fail(&e)
        }
    }
}
