//! The command line: parses arguments, calls the library, and is the one place
//! that turns errors into `error: <where>: <what>` lines and exit codes.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::friction::{ForceLimit, ModelParams, ParamError};
use crate::render;
use crate::scenario::{self, RunSettings, ScenarioError, ScenarioParams};
use crate::settings::{self, SetError};

/// Exit code for bad input (a flag, a parameter, a file).
pub const EXIT_BAD_INPUT: u8 = 2;

/// Renders friction on a haptic device, runs friction-perception experiments
/// and analyses them.
#[derive(Debug, Parser)]
#[command(name = "frictionlab", version, arg_required_else_help = true)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Runs one friction model through a scripted scenario and writes the time
    /// series (CSV) and optionally its figure (SVG).
    Render(RenderArgs),
    /// Lists the friction models and scenarios with their default parameters
    /// (the names `render --set` accepts), as JSON.
    Models,
}

#[derive(Debug, clap::Args)]
struct RenderArgs {
    /// Friction model: god-object-constant, god-object-time-varying,
    /// stick-slip-tactile, stick-slip-force, karnopp, dahl, viscous, none.
    #[arg(long)]
    model: String,
    /// Scenario: spidar-slide, sinusoidal-stroke, coupled-block.
    #[arg(long)]
    scenario: String,
    /// Override a parameter: a model parameter (`mu_s=1.2`), a scenario
    /// parameter (`scenario.slide_speed_m_s=0.05`), the step rate
    /// (`rate_hz=5000`; default: the model's loop rate) or the device's force
    /// limit (`force_limit_n=9.48`). Repeatable.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// The time series, CSV.
    #[arg(long)]
    out: PathBuf,
    /// A figure of force (and vibration) over time, SVG.
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// A problem with the user's input: printed as `error: <place>: <message>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UserError {
    /// The flag or file, with the place inside it (`--set mu_s`).
    pub place: String,
    /// What is wrong.
    pub message: String,
}

impl UserError {
    fn new(place: impl Into<String>, message: impl Into<String>) -> Self {
        UserError {
            place: place.into(),
            message: message.into(),
        }
    }
}

impl std::fmt::Display for UserError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "error: {}: {}", self.place, self.message)
    }
}

/// Runs the command line and returns the process exit code.
#[must_use]
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // clap prints help/version to stdout (exit 0) and usage errors
            // to stderr (exit 2).
            let _ = e.print();
            return ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(EXIT_BAD_INPUT));
        }
    };
    let result = match cli.command {
        Command::Render(args) => render_command(&args),
        Command::Models => {
            println!("{}", models_json());
            Ok(())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(errors) => {
            for e in errors {
                eprintln!("{e}");
            }
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

/// Every model's and scenario's default parameters, pretty JSON.
fn models_json() -> String {
    let models: Vec<_> = ModelParams::NAMES
        .iter()
        .filter_map(|n| ModelParams::default_for(n))
        .collect();
    let scenarios: Vec<_> = ScenarioParams::NAMES
        .iter()
        .filter_map(|n| ScenarioParams::default_for(n))
        .collect();
    serde_json::to_string_pretty(&serde_json::json!({
        "models": models,
        "scenarios": scenarios,
    }))
    .unwrap_or_default()
}

/// What `render` runs, after every flag was checked.
struct RenderPlan {
    model: ModelParams,
    scenario: ScenarioParams,
    settings: RunSettings,
}

fn render_command(args: &RenderArgs) -> Result<(), Vec<UserError>> {
    if let Some(plot) = &args.plot
        && plot.extension().and_then(|e| e.to_str()) != Some("svg")
    {
        return Err(vec![UserError::new(
            "--plot",
            format!(
                "{}: only SVG figures are written (use a .svg name)",
                plot.display()
            ),
        )]);
    }
    let plan = render_plan(&args.model, &args.scenario, &args.set)?;
    let samples = scenario::run(&plan.model, &plan.scenario, plan.settings).map_err(|e| {
        vec![match e {
            ScenarioError::Model(p) => param_error("", &p),
            ScenarioError::Scenario(p) => param_error("scenario.", &p),
            ScenarioError::Rate(r) => UserError::new(
                "--set rate_hz",
                format!("must be finite and greater than 0, got {r}"),
            ),
            ScenarioError::TooLong(_) => UserError::new("--scenario", e.to_string()),
        }]
    })?;
    let vibration = plan.model.has_vibration();
    let text = render::csv(&samples, vibration);
    render::write_atomically(&args.out, text.as_bytes()).map_err(|e| {
        vec![UserError::new(
            "--out",
            format!("{}: {e}", args.out.display()),
        )]
    })?;
    if let Some(plot) = &args.plot {
        let title = format!("{} / {}", plan.model.name(), plan.scenario.name());
        let svg = render::plot_svg(&samples, &title, vibration)
            .map_err(|e| vec![UserError::new("--plot", e)])?;
        render::write_atomically(plot, svg.as_bytes())
            .map_err(|e| vec![UserError::new("--plot", format!("{}: {e}", plot.display()))])?;
    }
    let onsets = samples.iter().filter(|s| s.slip_onset).count();
    let (t0, t1) = (
        samples.first().map_or(0.0, |s| s.t_s),
        samples.last().map_or(0.0, |s| s.t_s),
    );
    println!(
        "{} / {}: {} samples at {} Hz, t = {t0:.3} .. {t1:.3} s, {onsets} stick-to-slip transitions -> {}",
        plan.model.name(),
        plan.scenario.name(),
        samples.len(),
        plan.settings.rate_hz,
        args.out.display()
    );
    Ok(())
}

fn param_error(prefix: &str, p: &ParamError) -> UserError {
    UserError::new(format!("--set {prefix}{}", p.field), p.message.clone())
}

fn set_error(prefix: &str, e: SetError) -> UserError {
    UserError::new(format!("--set {prefix}{}", e.name), e.message)
}

/// Resolves the model, the scenario and every `--set`, reporting every error.
fn render_plan(model: &str, scenario: &str, sets: &[String]) -> Result<RenderPlan, Vec<UserError>> {
    let mut errors = Vec::new();
    let model_base = ModelParams::default_for(model);
    if model_base.is_none() {
        errors.push(UserError::new(
            "--model",
            format!(
                "unknown model '{model}'; known: {}",
                ModelParams::NAMES.join(", ")
            ),
        ));
    }
    let scenario_base = ScenarioParams::default_for(scenario);
    if scenario_base.is_none() {
        errors.push(UserError::new(
            "--scenario",
            format!(
                "unknown scenario '{scenario}'; known: {}",
                ScenarioParams::NAMES.join(", ")
            ),
        ));
    }
    let (mut model_sets, mut scenario_sets) = (Vec::new(), Vec::new());
    let (mut rate_hz, mut limit_n) = (None, None);
    for text in sets {
        let (name, value) = match settings::split_setting(text) {
            Ok(pair) => pair,
            Err(e) => {
                errors.push(set_error("", e));
                continue;
            }
        };
        match name {
            "rate_hz" | "force_limit_n" => match value.parse::<f64>() {
                Ok(x) if name == "rate_hz" => rate_hz = Some(x),
                Ok(x) => limit_n = Some(x),
                Err(_) => errors.push(UserError::new(
                    format!("--set {name}"),
                    format!("expected a number, got '{value}'"),
                )),
            },
            _ => match name.strip_prefix("scenario.") {
                Some(rest) => scenario_sets.push((rest, value)),
                None => model_sets.push((name, value)),
            },
        }
    }
    let limit = match ForceLimit::new(limit_n.unwrap_or(crate::friction::DEFAULT_FORCE_LIMIT_N)) {
        Ok(l) => Some(l),
        Err(e) => {
            errors.push(param_error("", &e));
            None
        }
    };
    let model = model_base.and_then(|base| {
        let what = format!("model {}", base.name());
        let (model, errs) = settings::apply_all(&base, "model", &what, &model_sets);
        errors.extend(errs.into_iter().map(|e| set_error("", e)));
        model
    });
    if let Some(m) = &model {
        errors.extend(m.validate().iter().map(|p| param_error("", p)));
    }
    let scenario = scenario_base.and_then(|base| {
        let what = format!("scenario {}", base.name());
        let (scenario, errs) = settings::apply_all(&base, "scenario", &what, &scenario_sets);
        errors.extend(errs.into_iter().map(|e| set_error("scenario.", e)));
        scenario
    });
    if let Some(s) = &scenario {
        errors.extend(s.validate().iter().map(|p| param_error("scenario.", p)));
    }
    match (model, scenario, limit) {
        (Some(model), Some(scenario), Some(limit)) if errors.is_empty() => {
            let rate_hz = rate_hz.unwrap_or_else(|| model.loop_rate_hz());
            Ok(RenderPlan {
                model,
                scenario,
                settings: RunSettings { rate_hz, limit },
            })
        }
        _ => Err(errors),
    }
}
