//! `negotiator play` as a person uses it: in a real terminal (tmux, keys
//! sent with send-keys) and in line mode (piped input). Both must write a
//! run directory `eval`'s schema reads, resume after a quit, and feed
//! `report`.

use super::support::{negotiator, scratch};
use negotiator::rundir::record::RolloutRecord;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The person's run directory under `dir`.
fn run_dir(dir: &Path) -> Option<std::path::PathBuf> {
    std::fs::read_dir(dir)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("human_")))
}

fn rollouts(dir: &Path) -> Vec<RolloutRecord> {
    let Some(run) = run_dir(dir) else { return Vec::new() };
    std::fs::read_to_string(run.join("rollouts.jsonl"))
        .unwrap_or_default()
        .lines()
        .map(|l| serde_json::from_str(l).expect("a rollout line of eval's schema"))
        .collect()
}

fn run_json(dir: &Path) -> serde_json::Value {
    let run = run_dir(dir).unwrap();
    serde_json::from_str(&std::fs::read_to_string(run.join("run.json")).unwrap()).unwrap()
}

fn report_reads(dir: &Path) {
    let run = run_dir(dir).unwrap();
    let out = negotiator().arg("report").arg(&run).arg("--out").arg(dir.join("report")).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("human:"), "report ranks the person");
}

fn play_lines(dir: &Path, name: &str, input: &str) -> String {
    let mut child = negotiator()
        .args(["play", "--name", name, "--scenario", "yield_standoff,pedestrian_feint", "--tier", "1", "-n", "1"])
        .arg("--output")
        .arg(dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn line_mode_plays_from_piped_input_quits_resumes_and_reports() {
    let dir = scratch("play-lines");
    // A few answers: the first episode is cut off by the end of input.
    let out = play_lines(&dir, "lin", "p9\ny 3\n");
    assert!(out.contains("Scene: "), "{out}");
    assert!(out.contains("Run the same command to go on"), "{out}");
    assert!(rollouts(&dir).is_empty());
    // Enough answers for both episodes; unreadable lines are asked again.
    let answers = format!("x\n{}", "p9\n".repeat(60));
    let out = play_lines(&dir, "lin", &answers);
    assert!(out.contains("not an answer"), "{out}");
    assert!(out.contains("All episodes played"), "{out}");
    let records = rollouts(&dir);
    assert_eq!(records.len(), 2);
    for r in &records {
        assert_eq!(r.model, "human:lin");
        assert!(r.turns.iter().all(|t| t.parse_errors.is_empty()));
        assert_eq!(r.turns.first().map(|t| t.turn), Some(1), "an interrupted episode is replayed from its start");
    }
    let info = run_json(&dir);
    assert_eq!(info["config"]["human"]["view"], "text");
    assert_eq!(info["invocations"], 2);
    assert_eq!(info["last_invocation"]["status"], "finished");
    // Outcomes and intents appear only in the end-of-run summary.
    assert!(out.contains("the other road user"), "{out}");
    report_reads(&dir);
}

struct Tmux {
    socket: String,
}

impl Tmux {
    fn available() -> bool {
        Command::new("tmux").arg("-V").output().is_ok_and(|o| o.status.success())
    }

    fn start(command: &str) -> Tmux {
        let socket = format!("negotiator-it-{}", std::process::id());
        let ok = Command::new("tmux")
            .args(["-L", &socket, "-f", "/dev/null", "new-session", "-d", "-s", "play", "-x", "80", "-y", "24"])
            .arg(command)
            .status()
            .unwrap()
            .success();
        assert!(ok, "tmux new-session");
        Tmux { socket }
    }

    fn keys(&self, keys: &[&str]) {
        Command::new("tmux").args(["-L", &self.socket, "send-keys", "-t", "play"]).args(keys).status().unwrap();
    }

    fn screen(&self) -> String {
        let out = Command::new("tmux").args(["-L", &self.socket, "capture-pane", "-p", "-t", "play"]).output().unwrap();
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    fn alive(&self) -> bool {
        Command::new("tmux")
            .args(["-L", &self.socket, "has-session", "-t", "play"])
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    }

    fn wait_for(&self, what: &str) -> String {
        let start = Instant::now();
        loop {
            let s = self.screen();
            if s.contains(what) {
                return s;
            }
            assert!(start.elapsed() < Duration::from_secs(20), "waited for {what:?}; screen:\n{s}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = Command::new("tmux").args(["-L", &self.socket, "kill-server"]).status();
    }
}

#[test]
fn a_person_plays_in_a_terminal_quits_and_resumes() {
    if !crate::support::tool_available(Tmux::available(), "tmux") {
        return;
    }
    let dir = scratch("play-tmux");
    let command = format!(
        "{} play --name tess --scenario yield_standoff --tier 1 -n 2 --output {}",
        env!("CARGO_BIN_EXE_negotiator"),
        dir.display()
    );
    let tmux = Tmux::start(&command);
    // The help screen first: the instructions the model gets as its system prompt.
    let help = tmux.wait_for("You are the driver");
    assert!(help.lines().count() <= 24 && help.lines().all(|l| l.chars().count() <= 80));
    tmux.keys(&["Enter"]);
    let scene = tmux.wait_for("Scene: ");
    assert!(scene.contains("episode 1 of 2"), "{scene}");
    // Full throttle until the first episode is over.
    tmux.keys(&["p", "9"]);
    let start = Instant::now();
    while rollouts(&dir).is_empty() {
        assert!(start.elapsed() < Duration::from_secs(30), "no episode finished:\n{}", tmux.screen());
        tmux.keys(&["Enter"]);
        std::thread::sleep(Duration::from_millis(60));
    }
    let over = tmux.wait_for("Episode over.");
    assert!(!over.contains("yielder") && !over.contains("committed"), "no outcome or intent shown:\n{over}");
    tmux.keys(&["Enter"]);
    tmux.wait_for("episode 2 of 2");
    tmux.keys(&["q"]);
    let start = Instant::now();
    while tmux.alive() {
        assert!(start.elapsed() < Duration::from_secs(10), "play did not quit:\n{}", tmux.screen());
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(rollouts(&dir).len(), 1);
    assert_eq!(run_json(&dir)["last_invocation"]["status"], "interrupted");
    drop(tmux);

    // The same command goes on with the unplayed episode.
    let tmux = Tmux::start(&command);
    tmux.wait_for("You are the driver");
    tmux.keys(&["Enter"]);
    tmux.wait_for("episode 2 of 2");
    tmux.keys(&["y", "5"]);
    let start = Instant::now();
    while rollouts(&dir).len() < 2 {
        assert!(start.elapsed() < Duration::from_secs(30), "the second episode did not finish:\n{}", tmux.screen());
        tmux.keys(&["Enter"]);
        std::thread::sleep(Duration::from_millis(60));
    }
    let records = rollouts(&dir);
    assert_eq!(records.iter().map(|r| r.seed).collect::<Vec<_>>(), [0, 1]);
    assert!(records.iter().all(|r| r.model == "human:tess"));
    drop(tmux);
    report_reads(&dir);
}

/// `--view picture`: each turn shows the one line a model gets with its
/// picture and names the file the picture was written to, which holds the
/// very PNG `eval --observation image` sends; the run is a picture run.
#[test]
fn a_person_plays_from_the_picture() {
    let dir = scratch("play-picture");
    let kind = negotiator::scenario::ScenarioKind::ALL[0];
    let mut child = negotiator()
        .args(["play", "--name", "pic", "--view", "picture", "--scenario", kind.name(), "--tier", "1", "-n", "1"])
        .arg("--output")
        .arg(&dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // One answer; the second turn's picture is read while play waits for
    // the next, then the end of input (save and quit).
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"y3\n").unwrap();
    let mut stdout = std::io::BufReader::new(child.stdout.take().unwrap());
    let (mut shown, mut pictures) = (String::new(), Vec::new());
    while pictures.len() < 2 {
        let mut line = String::new();
        assert!(std::io::BufRead::read_line(&mut stdout, &mut line).unwrap() > 0, "{shown}");
        if let Some(path) = line.strip_prefix("Picture: ").and_then(|l| l.split(" (").next()) {
            pictures.push(path.to_string());
        }
        shown.push_str(&line);
    }
    assert!(shown.contains("Turn 1 of ") && !shown.contains("Scene: "), "{shown}");
    let path = pictures[1].clone();
    let png = std::fs::read(&path).unwrap();
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // The file held the latest turn's picture: the second, after one
    // answer; it is gone once play ends (the run keeps the scene texts).
    let set = negotiator::scenario::ScenarioSet::default();
    let mut episode = negotiator::episode::Episode::new(set.get(kind), negotiator::scenario::Tier::T1, 0);
    episode.step(negotiator::action::Action::new(negotiator::action::Maneuver::Yield, 3.0 / 9.0));
    assert_eq!(png, negotiator::picture::png(episode.observation()).unwrap());
    assert!(!std::path::Path::new(&path).exists(), "{path} left behind");
    let info = run_json(&dir);
    assert_eq!(
        (info["config"]["human"]["view"].as_str(), info["config"]["pictures"]["observation"].as_str()),
        (Some("picture"), Some("image"))
    );
}
