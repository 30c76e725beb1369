//! `ftpd3d view`: its own flags ([`ViewArgs`]) and the run flags of a view's state. A view's state
//! is a list of run flags without their dashes, with the flags' own value syntax, as the page's
//! URL carries them (`slice=z%3D0.25&weight=unweighted`): [`base_state`] reads them from the
//! command line, [`merge_state`] lays a URL's over them, [`state_args`] parses them with the main
//! run's own parser, and [`reproduce_state`] and [`command_line`] write the command line that
//! computes the samples a view has taken. The server itself is `crate::view`, which names no flag.

use super::args::RunArgs;
use super::report::shell_quote;
use clap::{Args, CommandFactory, Parser};

/// `ftpd3d view`: the main run's flags, and where to serve.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// Port on 127.0.0.1 to listen on [default: a free one].
    #[arg(long, value_name = "N")]
    pub port: Option<u16>,
    /// Open the page in the default browser (xdg-open); without it nothing is opened.
    #[arg(long)]
    pub open: bool,
    #[command(flatten)]
    pub run: RunArgs,
}

/// One run flag of a view's state: its long name without dashes, and its value (empty for a
/// switch such as `uniform`).
pub type Pair = (String, String);

/// The run flags only the command line sets (where files go, what is loaded, what is printed):
/// a URL cannot change them.
const FIXED: [&str; 7] = [
    "scene",
    "output",
    "resume",
    "checkpoint-every",
    "explain",
    "quiet",
    "strict",
];

/// The flags that choose the domain: a URL that gives one of them replaces all of them.
const DOMAIN: [&str; 6] = ["slice", "slices", "plane", "camera", "eye", "target"];

/// The flags that add to a list (lights, the scene's lights' scales): a URL's values replace the
/// command line's, and each of its values counts.
const LISTS: [&str; 3] = ["point-light", "sun", "light-scale"];

/// The sampling flags: a view runs them as given; [`reproduce_state`] writes its own.
const SAMPLING: [&str; 8] = [
    "spp",
    "batches",
    "pass-spp",
    "time",
    "target-error",
    "adaptive",
    "uniform",
    "adaptive-cap",
];

/// The main run's flags alone, for parsing a state.
#[derive(Parser, Debug)]
#[command(name = "ftpd3d")]
struct StateCli {
    #[command(flatten)]
    run: RunArgs,
}

/// Whether the run flag `name` takes a value (else it is a switch); `None` for no such flag.
fn takes_value(name: &str) -> Option<bool> {
    let cmd = StateCli::command();
    let arg = cmd.get_arguments().find(|a| a.get_long() == Some(name))?;
    Some(arg.get_action().takes_values())
}

/// The long name of the short flag `c`.
fn long_of_short(c: char) -> Option<String> {
    let cmd = StateCli::command();
    let arg = cmd.get_arguments().find(|a| a.get_short() == Some(c))?;
    arg.get_long().map(str::to_string)
}

/// The command line's run flags after `view` (`raw`, as the shell gave them) as a state, in their
/// order, without `--port` and `--open`; split into those a URL may change and the [`FIXED`] ones.
pub fn base_state(raw: &[String]) -> Result<(Vec<Pair>, Vec<Pair>), String> {
    let mut pairs = Vec::new();
    let mut i = 0;
    while i < raw.len() {
        let a = &raw[i];
        i += 1;
        let (name, inline) = if let Some(long) = a.strip_prefix("--") {
            match long.split_once('=') {
                Some((n, v)) => (n.to_string(), Some(v.to_string())),
                None => (long.to_string(), None),
            }
        } else if let Some(c) = a.strip_prefix('-').and_then(|s| s.chars().next()) {
            let long = long_of_short(c).ok_or_else(|| format!("unexpected argument '{a}'"))?;
            let rest = &a[1 + c.len_utf8()..];
            (long, (!rest.is_empty()).then(|| rest.to_string()))
        } else {
            return Err(format!("unexpected argument '{a}'"));
        };
        if name == "port" || name == "open" {
            if name == "port" && inline.is_none() {
                i += 1;
            }
            continue;
        }
        let value = match (takes_value(&name), inline) {
            (None, _) => return Err(format!("unexpected argument '--{name}'")),
            (Some(false), _) => String::new(),
            (Some(true), Some(v)) => v,
            // `--camera` alone names the first camera.
            (Some(true), None)
                if name == "camera" && raw.get(i).is_none_or(|n| n.starts_with("--")) =>
            {
                String::new()
            }
            (Some(true), None) => {
                let v = raw
                    .get(i)
                    .ok_or_else(|| format!("--{name} needs a value"))?;
                i += 1;
                v.clone()
            }
        };
        pairs.push((name, value));
    }
    let (fixed, free) = pairs
        .into_iter()
        .partition(|(n, _)| FIXED.contains(&n.as_str()));
    Ok((free, fixed))
}

/// The state of a URL's run flags (`url`, without `token` and `channel`) laid over `base`: a flag
/// the URL gives replaces the base's values of it (a domain flag replaces every domain flag), the
/// last of several values wins except for the lights, which add up. A switch given `false`, `off`
/// or `0` is off. Refuses the [`FIXED`] flags.
pub fn merge_state(base: &[Pair], url: &[Pair]) -> Result<Vec<Pair>, String> {
    for (k, _) in url {
        if FIXED.contains(&k.as_str()) {
            return Err(format!(
                "{k}: set on the command line that started the view, not in the URL"
            ));
        }
    }
    let given = |k: &str| url.iter().any(|(u, _)| u == k);
    let domain_given = url.iter().any(|(k, _)| DOMAIN.contains(&k.as_str()));
    let mut out: Vec<Pair> = base
        .iter()
        .filter(|(k, _)| !(given(k) || domain_given && DOMAIN.contains(&k.as_str())))
        .cloned()
        .collect();
    for (n, (k, v)) in url.iter().enumerate() {
        let later = url[n + 1..].iter().any(|(u, _)| u == k);
        if later && !LISTS.contains(&k.as_str()) {
            continue;
        }
        if takes_value(k) == Some(false) && matches!(v.as_str(), "false" | "off" | "0") {
            continue;
        }
        out.push((k.clone(), v.clone()));
    }
    Ok(out)
}

/// The main run's arguments of `state` (with the [`FIXED`] flags `fixed`), parsed by the main
/// run's own parser: its errors are the command line's.
pub fn state_args(fixed: &[Pair], state: &[Pair]) -> Result<RunArgs, String> {
    StateCli::try_parse_from(std::iter::once("ftpd3d".to_string()).chain(flags(fixed, state)))
        .map(|c| c.run)
        .map_err(|e| e.render().to_string().trim_end().to_string())
}

/// `--name=value` (or `--name` for a switch) for every pair, fixed ones first.
fn flags(fixed: &[Pair], state: &[Pair]) -> Vec<String> {
    fixed
        .iter()
        .chain(state)
        .map(|(k, v)| {
            if takes_value(k) == Some(false) {
                format!("--{k}")
            } else {
                format!("--{k}={v}")
            }
        })
        .collect()
}

/// The state as URL query parameters (`slice=z%3D0.25&weight=unweighted`; a switch as its name).
pub fn state_query(state: &[Pair]) -> String {
    state
        .iter()
        .map(|(k, v)| {
            if takes_value(k) == Some(false) {
                k.clone()
            } else {
                format!("{k}={}", percent_encode(v))
            }
        })
        .collect::<Vec<_>>()
        .join("&")
}

/// `s` with every byte other than `A-Z a-z 0-9 - _ . ~` as `%XX`.
pub fn percent_encode(s: &str) -> String {
    s.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'_' | b'.' | b'~' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// The samples a view has taken, as the sampling flags of the command line that takes the same.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Samples {
    /// The first `passes` passes of a sample cap split into passes: `--spp SPP --batches PASSES`
    /// cuts the cap the same way (the first passes get the remainder in both).
    Split { spp: u64, passes: u32 },
    /// Passes of `pass_spp` samples per cell: `--spp SPP --pass-spp N`, adaptive (with its cap)
    /// or uniform as the view ran.
    Every {
        spp: u64,
        pass_spp: u32,
        adaptive_cap: Option<u32>,
    },
}

/// The state of the command line that takes the samples `samples` of the view's `state`: the same
/// flags but the sampling ones, which say how many samples in which passes.
pub fn reproduce_state(state: &[Pair], samples: Samples) -> Vec<Pair> {
    let mut out: Vec<Pair> = state
        .iter()
        .filter(|(k, _)| !SAMPLING.contains(&k.as_str()))
        .cloned()
        .collect();
    let mut add = |k: &str, v: String| out.push((k.to_string(), v));
    match samples {
        Samples::Split { spp, passes } => {
            add("spp", spp.to_string());
            add("batches", passes.to_string());
        }
        Samples::Every {
            spp,
            pass_spp,
            adaptive_cap,
        } => {
            add("spp", spp.to_string());
            add("pass-spp", pass_spp.to_string());
            match adaptive_cap {
                Some(cap) => {
                    add("adaptive", String::new());
                    add("adaptive-cap", cap.to_string());
                }
                None => add("uniform", String::new()),
            }
        }
    }
    out
}

/// The command line of `state` with the [`FIXED`] flags `fixed` (but those of printing and
/// resuming), writing to `output`, quoted for a shell.
pub fn command_line(fixed: &[Pair], state: &[Pair], output: &str) -> String {
    let fixed = fixed.iter().filter(|(k, _)| {
        !matches!(
            k.as_str(),
            "output" | "quiet" | "resume" | "checkpoint-every"
        )
    });
    let mut words = vec!["ftpd3d".to_string()];
    for (k, v) in fixed.chain(state) {
        words.push(format!("--{k}"));
        if takes_value(k) != Some(false) {
            words.push(shell_quote(v));
        }
    }
    words.push(format!("-o {}", shell_quote(output)));
    words.join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    fn p(k: &str, v: &str) -> Pair {
        (k.into(), v.into())
    }

    #[test]
    fn command_line_to_state_and_back() {
        let raw = s(&[
            "--scene",
            "a.obj",
            "--slice",
            "z=0",
            "--res=32",
            "--port",
            "8000",
            "--open",
            "-q",
            "--t0",
            "-1",
            "--uniform",
            "-o",
            "x.exr",
        ]);
        let (free, fixed) = base_state(&raw).unwrap();
        assert_eq!(
            free,
            vec![
                p("slice", "z=0"),
                p("res", "32"),
                p("t0", "-1"),
                p("uniform", "")
            ]
        );
        assert_eq!(
            fixed,
            vec![p("scene", "a.obj"), p("quiet", ""), p("output", "x.exr")]
        );
        assert_eq!(state_query(&free), "slice=z%3D0&res=32&t0=-1&uniform");
        let args = state_args(&fixed, &free).unwrap();
        assert_eq!((args.res, args.estimator.t0), (32, Some(-1.0)));
        assert!(args.uniform && args.quiet);
    }

    #[test]
    fn url_replaces_flags_and_domains() {
        let base = vec![
            p("slice", "z=0"),
            p("res", "32"),
            p("point-light", "0,0,0:1,1,1"),
        ];
        let url = vec![
            p("plane", "origin=0,0,0 normal=1,0,0"),
            p("res", "16"),
            p("res", "24"),
            p("uniform", "off"),
        ];
        let m = merge_state(&base, &url).unwrap();
        assert_eq!(
            m,
            vec![
                p("point-light", "0,0,0:1,1,1"),
                p("plane", "origin=0,0,0 normal=1,0,0"),
                p("res", "24")
            ]
        );
        assert!(merge_state(&base, &[p("output", "/etc/x")]).is_err());
        let e = state_args(&[], &[p("res", "many")]).unwrap_err();
        assert!(e.contains("--res"), "{e}");
    }

    #[test]
    fn reproducing_command() {
        let fixed = vec![p("scene", "scenes/a b.obj"), p("output", "o.exr")];
        let state = vec![p("slice", "z=0"), p("spp", "64"), p("flatland", "")];
        let again = reproduce_state(&state, Samples::Split { spp: 24, passes: 3 });
        let c = command_line(&fixed, &again, "out/o.exr");
        assert_eq!(
            c,
            "ftpd3d --scene 'scenes/a b.obj' --slice z=0 --flatland --spp 24 --batches 3 -o out/o.exr"
        );
    }
}
