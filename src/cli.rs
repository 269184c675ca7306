//! Command-line interface: argument types (clap) and the jobs they run.

use crate::error::Result;
use crate::scene::Scene;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Cycle-level model of the shelling ray-casting machine for radiosity form factors.
#[derive(Parser, Debug)]
#[command(name = "shellsim", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Generate, inspect or import scenes.
    #[command(subcommand)]
    Scene(SceneCmd),
}

#[derive(Subcommand, Debug)]
pub enum SceneCmd {
    /// Validate a scene (JSON or OBJ) and print its statistics.
    Info {
        /// The scene file (.json or .obj).
        file: PathBuf,
    },
}

/// Runs the job the command line asks for.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Some(Command::Scene(SceneCmd::Info { file })) => {
            let scene = Scene::load(&file)?;
            println!("scene     {}", scene.name);
            println!("patches   {}", scene.patches.len());
            println!("area      {:.6}", scene.total_area());
            Ok(())
        }
        None => Ok(()),
    }
}
