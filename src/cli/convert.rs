//! `pathmix convert`: a Mitsuba 3 XML scene written as the pathmix TOML scene it
//! renders as.

use super::Failure;
use clap::Args;
use pathmix::output;
use pathmix::paths::{self, PathUse};
use pathmix::scene::Scene;
use pathmix::scene::mitsuba::{self, Converted, Define};
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// Mitsuba 3 scene (XML).
    pub scene: PathBuf,
    /// The pathmix scene to write (TOML); mesh paths in it are relative to its folder.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Set the scene's `$NAME` parameter, as `mitsuba -D` (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<Define>,
}

pub fn convert(args: ConvertArgs) -> Result<(), Failure> {
    let text = paths::read_input_text(&args.scene).map_err(|e| {
        Failure::input(format!(
            "{}: cannot read the scene file: {e}",
            args.scene.display()
        ))
    })?;
    if !mitsuba::is_mitsuba(&args.scene, &text) {
        return Err(Failure::input(format!(
            "{}: not a Mitsuba XML scene (a .xml file with a <scene version=...> root)",
            args.scene.display()
        )));
    }
    if args.output.extension().and_then(|e| e.to_str()) != Some("toml") {
        return Err(Failure::input(format!(
            "{}: the output must be a .toml file",
            args.output.display()
        )));
    }
    output::check_writable(&args.output).map_err(Failure::input)?;
    let folder = args
        .output
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let folder = folder
        .canonicalize()
        .map_err(|e| Failure::input(format!("{}: {e}", folder.display())))?;
    let converted = Converted::read(&args.scene, &args.define).map_err(Failure::input)?;
    let toml = converted.to_toml(&folder, &args.scene);
    // What is written must read back as the scene `render` would render.
    let scene = Scene::parse(&toml, &args.output.display().to_string())
        .map_err(|e| Failure::input(converted.locate(e)))?;
    // The output must replace none of the files it is converted from.
    let inputs = [args.scene.as_path()]
        .into_iter()
        .chain(converted.includes.iter().map(PathBuf::as_path))
        .chain(scene.inputs.iter().map(PathBuf::as_path));
    let mut uses: Vec<PathUse<&str>> = inputs.map(|p| PathUse::input("SCENE", p)).collect();
    uses.push(PathUse::output("-o", &args.output));
    if let Some(collision) = paths::collision(&uses) {
        return Err(Failure::input(collision));
    }
    output::write_atomically(&args.output, |w| w.write_all(toml.as_bytes()))
        .map_err(Failure::runtime)?;
    super::print_approximations(&args.scene, &converted.warnings);
    println!("wrote {}", args.output.display());
    Ok(())
}
