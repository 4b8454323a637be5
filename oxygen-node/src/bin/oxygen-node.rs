//! A render node: joins a rig and renders its share of the views until the
//! rig's coordinator leaves.
//!
//! ```text
//! oxygen-node --rig NAME --connect ENDPOINT [--name NAME] [--gpu N]
//!             [--listen ENDPOINT] [--deterministic] [--wait SECONDS]
//! ```
//!
//! `--connect` is the coordinator's Zenoh endpoint (`tcp/HOST:PORT`);
//! `--name` must be unique in the rig (default `node-PID`); `--gpu N`
//! renders on the machine's N-th GPU (default 0); `--deterministic`
//! renders in the deterministic mode (the same pixels on any node of one
//! kind of GPU and driver); `--wait` is how long to wait for the
//! coordinator (default 60 s). Logs go to stderr (`RUST_LOG` filters them).

use std::process::ExitCode;
use std::time::Duration;

use oxygen_node::{MAX_GPU, NodeOptions, run_node};

const USAGE: &str = "usage: oxygen-node --rig NAME --connect ENDPOINT [--name NAME] [--gpu N] [--listen ENDPOINT] [--deterministic] [--wait SECONDS]";

fn parse(mut args: impl Iterator<Item = String>) -> Result<NodeOptions, String> {
    let mut options = NodeOptions::new("", format!("node-{}", std::process::id()), "");
    options.net.connect.clear();
    while let Some(arg) = args.next() {
        let mut value = |name: &str| args.next().ok_or_else(|| format!("{name} needs a value\n{USAGE}"));
        match arg.as_str() {
            "--rig" => options.rig = value("--rig")?,
            "--name" => options.name = value("--name")?,
            "--connect" => options.net.connect.push(value("--connect")?),
            "--listen" => options.net.listen.push(value("--listen")?),
            "--gpu" => {
                options.gpu = value("--gpu")?.parse().map_err(|e| format!("--gpu: {e}"))?;
                // The node opens a device on every GPU up to this one.
                if options.gpu >= MAX_GPU {
                    return Err(format!("--gpu: {} (0 to {})", options.gpu, MAX_GPU - 1));
                }
            }
            "--wait" => {
                let seconds: f64 = value("--wait")?.parse().map_err(|e| format!("--wait: {e}"))?;
                if !(seconds.is_finite() && seconds > 0.0) {
                    return Err("--wait: a number of seconds above 0".into());
                }
                options.coordinator_wait = Duration::from_secs_f64(seconds);
            }
            "--deterministic" => options.renderer.deterministic = true,
            "-h" | "--help" => return Err(USAGE.into()),
            other => return Err(format!("unknown argument {other:?}\n{USAGE}")),
        }
    }
    if options.rig.is_empty() || options.net.connect.is_empty() && options.net.listen.is_empty() {
        return Err(format!("--rig and --connect (or --listen) are needed\n{USAGE}"));
    }
    Ok(options)
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn,oxygen_node=info")),
        )
        .with_writer(std::io::stderr)
        .init();
    let options = match parse(std::env::args().skip(1)) {
        Ok(options) => options,
        Err(message) => {
            eprintln!("{message}");
            return ExitCode::from(2);
        }
    };
    match run_node(&options) {
        Ok(summary) => {
            eprintln!(
                "oxygen-node {}: {} frames, {} view-frames, {} MB of images sent, {} KB of scene received, on {}",
                options.name,
                summary.frames,
                summary.view_frames,
                summary.bytes_sent / 1_000_000,
                summary.scene_bytes / 1000,
                summary.adapter
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("oxygen-node {}: {e}", options.name);
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_args(args: &[&str]) -> Result<NodeOptions, String> {
        parse(args.iter().map(|a| a.to_string()))
    }

    /// `--wait` takes a finite number of seconds above 0: 0, a negative
    /// number, infinity and NaN are refused (a node must not wait for ever
    /// or not at all), a fraction is kept.
    #[test]
    fn wait_takes_a_finite_positive_number_of_seconds() {
        let with_wait = |w: &str| parse_args(&["--rig", "r", "--connect", "tcp/127.0.0.1:1", "--wait", w]);
        for bad in ["0", "-1", "inf", "NaN"] {
            let error = with_wait(bad).err().unwrap_or_else(|| panic!("--wait {bad} accepted"));
            assert!(error.contains("--wait"), "--wait {bad}: {error}");
        }
        let options = with_wait("0.5").expect("--wait 0.5");
        assert_eq!(options.coordinator_wait, Duration::from_millis(500));
    }

    /// A node needs its rig's name and somewhere to reach it: a rig without
    /// an endpoint, or an endpoint without a rig, is refused; `--listen`
    /// serves as well as `--connect`.
    #[test]
    fn a_rig_and_an_endpoint_are_both_needed() {
        for args in [&["--rig", "r"][..], &["--connect", "tcp/127.0.0.1:1"], &["--listen", "tcp/127.0.0.1:1"], &[]] {
            let error = parse_args(args).err().unwrap_or_else(|| panic!("{args:?} accepted"));
            assert!(error.contains("--rig and --connect"), "{args:?}: {error}");
        }
        assert!(parse_args(&["--rig", "r", "--listen", "tcp/127.0.0.1:1"]).is_ok());
        assert!(parse_args(&["--rig", "r", "--connect", "tcp/127.0.0.1:1"]).is_ok());
    }
}
