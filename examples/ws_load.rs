//! A small load generator speaking OpenEnv's WebSocket messages, for
//! `scripts/bench/env_server.sh`: SESSIONS concurrent sessions, each
//! playing episodes (reset, then steps until `done`) for SECONDS; prints one
//! JSON line with steps per second and step round-trip latency percentiles,
//! and, given the server's PID, its CPU time per step (user + system, and
//! each) and peak memory.
//! `cargo run --release --example ws_load -- URL SESSIONS SECONDS RESET_JSON ACTION_JSON [PID]`
use futures_util::{SinkExt, StreamExt};
use std::time::{Duration, Instant};
use tokio_tungstenite::tungstenite::Message;

/// User and system CPU seconds of a process, and its peak resident memory (KiB).
fn process_usage(pid: u32) -> Option<((f64, f64), u64)> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = after.split_whitespace().collect();
    let user: f64 = fields.get(11)?.parse().ok()?;
    let system: f64 = fields.get(12)?.parse().ok()?;
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let hwm = status.lines().find(|l| l.starts_with("VmHWM:"))?.split_whitespace().nth(1)?.parse().ok()?;
    Some(((user / 100.0, system / 100.0), hwm))
}

async fn session(url: String, until: Instant, reset: String, action: String) -> Vec<u32> {
    let (mut ws, _) = tokio_tungstenite::connect_async(url.as_str()).await.expect("connect");
    let mut latencies = Vec::new();
    let reset = format!("{{\"type\":\"reset\",\"data\":{reset}}}");
    let step = format!("{{\"type\":\"step\",\"data\":{action}}}");
    'episodes: while Instant::now() < until {
        let mut message = reset.clone();
        let mut is_step = false;
        loop {
            let sent = Instant::now();
            if ws.send(Message::text(message.clone())).await.is_err() {
                break 'episodes;
            }
            let reply = loop {
                match ws.next().await {
                    Some(Ok(Message::Text(t))) => break t,
                    Some(Ok(_)) => continue,
                    _ => break 'episodes,
                }
            };
            if is_step {
                latencies.push(sent.elapsed().as_micros() as u32);
            }
            let value: serde_json::Value = serde_json::from_str(reply.as_str()).expect("a JSON reply");
            if value["type"] != "observation" {
                panic!("server error: {value}");
            }
            if value["data"]["done"] == true || Instant::now() >= until {
                break;
            }
            message = step.clone();
            is_step = true;
        }
    }
    let _ = ws.close(None).await;
    latencies
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 6 {
        eprintln!("usage: ws_load URL SESSIONS SECONDS RESET_JSON ACTION_JSON [PID]");
        std::process::exit(2);
    }
    let (url, sessions, seconds) = (a[1].clone(), a[2].parse::<usize>().unwrap(), a[3].parse::<f64>().unwrap());
    let pid: Option<u32> = a.get(6).and_then(|p| p.parse().ok());
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap();
    let before = pid.and_then(process_usage);
    let started = Instant::now();
    let until = started + Duration::from_secs_f64(seconds);
    let mut all: Vec<u32> = runtime.block_on(async {
        let tasks: Vec<_> =
            (0..sessions).map(|_| tokio::spawn(session(url.clone(), until, a[4].clone(), a[5].clone()))).collect();
        let mut all = Vec::new();
        for t in tasks {
            all.extend(t.await.unwrap());
        }
        all
    });
    let elapsed = started.elapsed().as_secs_f64();
    let after = pid.and_then(process_usage);
    all.sort_unstable();
    let pct = |p: f64| all.get(((all.len() as f64 - 1.0) * p).round() as usize).map_or(0.0, |&us| us as f64 / 1000.0);
    let steps = all.len() as f64;
    let per_step = |pick: fn((f64, f64)) -> f64| match (before, after) {
        (Some((b, _)), Some((a, _))) if steps > 0.0 => serde_json::json!((pick(a) - pick(b)) / steps * 1e6),
        _ => serde_json::Value::Null,
    };
    let line = serde_json::json!({
        "sessions": sessions,
        "steps": all.len(),
        "steps_per_s": steps / elapsed,
        "latency_ms": {"p50": pct(0.50), "p90": pct(0.90), "p99": pct(0.99)},
        "server_cpu_us_per_step": per_step(|(user, system)| user + system),
        "server_user_us_per_step": per_step(|(user, _)| user),
        "server_system_us_per_step": per_step(|(_, system)| system),
        "server_peak_rss_mib": after.map(|(_, kb)| kb as f64 / 1024.0),
    });
    println!("{line}");
}
