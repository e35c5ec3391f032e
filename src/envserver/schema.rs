//! The documents `env-server` publishes about itself: `/schema` (JSON
//! schemas of the action, the observation and the state), `/metadata` (the
//! environment, its version, scenarios, tiers and feature layout) and
//! `/openapi.json` (the HTTP API, as OpenEnv's validator reads it). The
//! observation and state schemas are derived from the types the server
//! sends, so they cannot drift from them.

use super::session::{DEFAULT_SCENARIO, DEFAULT_TIER, EnvObservation, EnvState, MAX_REPLY_BYTES};
use crate::action::Maneuver;
use crate::features::{discrete_actions_json, feature_names};
use crate::scenario::{ScenarioKind, Tier};
use serde_json::{Value, json};

/// The version of OpenEnv's HTTP API this server implements (OpenAPI's
/// `info.version`, which OpenEnv's validator reads as the standard).
pub(crate) const OPENENV_API_VERSION: &str = "1.0.0";

pub(crate) const DESCRIPTION: &str = "Drive an automated car through a short traffic negotiation (an unsignalled \
     intersection, an unmarked crosswalk, an on-ramp merge) whose other road user hides its intent: read it from \
     its motion and drive accordingly. Each step is one decision held for 0.5 s.";

/// How the reward is paid (also in docs/env-server.md).
pub(crate) const REWARD: &str = "0 on every step but the last; on the step that ends the episode, the episode \
     reward in [-1, 1] (collision -1; timeout in [-0.5, 0.3] by progress; success in [0.9, 1] by efficiency and \
     comfort), the same number `eval` records.";

/// The action's JSON schema. `reply` is the one required field so that a
/// harness holding a reply that is not one JSON object (prose around it, a
/// code fence) can send it whole; a reply that is one JSON object may be
/// sent as the object itself. Both are read by `eval`'s parser.
pub(crate) fn action_schema() -> Value {
    let maneuvers: Vec<&str> = Maneuver::ALL.iter().map(|m| m.name()).collect();
    json!({
        "title": "NegotiatorAction",
        "description": "One decision. Send the model's whole reply as `reply`, or the benchmark's action object \
            itself ({\"reasoning\", \"maneuver\", \"acceleration\", \"steering\"}) without `reply`. Either is read by \
            the protective parser `eval` uses: JSON inside prose, code fences and <think> blocks is found; anything \
            it cannot trust is a parse error and drives as a firm stop (reported in the observation's \
            `parse_errors`).",
        "type": "object",
        "properties": {
            "reply": {
                "type": "string",
                "description": format!("The model's whole reply (at most {MAX_REPLY_BYTES} bytes are read; a longer one is a parse error)."),
            },
            "reasoning": {"type": "string", "description": "One or two short sentences (recorded, not scored)."},
            "maneuver": {"type": "string", "enum": maneuvers, "description": "How the car is controlled this turn."},
            "acceleration": {"type": "number", "minimum": -1, "maximum": 1, "description": "Strength inside the maneuver's band (its sign is ignored)."},
            "steering": {"type": "number", "minimum": -1, "maximum": 1, "description": "Ignored (the task is longitudinal)."},
            "metadata": {"type": "object", "description": "Ignored."},
        },
        "required": ["reply"],
    })
}

fn schema_of<T: schemars::JsonSchema>() -> Value {
    serde_json::to_value(schemars::schema_for!(T)).expect("a JSON schema serialises")
}

/// `GET /schema`.
pub(crate) fn schemas() -> Value {
    json!({
        "action": action_schema(),
        "observation": schema_of::<EnvObservation>(),
        "state": schema_of::<EnvState>(),
    })
}

/// `GET /metadata`.
pub(crate) fn metadata() -> Value {
    let scenarios: Vec<&str> = ScenarioKind::ALL.iter().map(|k| k.name()).collect();
    let tiers: Vec<u8> = Tier::ALL.iter().map(|t| t.number()).collect();
    json!({
        "name": "negotiator",
        "description": DESCRIPTION,
        "version": env!("CARGO_PKG_VERSION"),
        "author": null,
        "documentation_url": null,
        "readme_content": null,
        "scenarios": scenarios,
        "tiers": tiers,
        "reset": {
            "scenario": format!("one of the scenarios (default {})", DEFAULT_SCENARIO.name()),
            "tier": format!("1, 2 or 3 (default {})", DEFAULT_TIER.number()),
            "seed": "a whole number from 0 to 2^64 - 1 (default: drawn below 2^53 and returned)",
            "view": "which forms the observations carry: full (default: instructions, scene, public, features), text (instructions and scene), public or features",
            "episode_id": "any string of 1 to 255 bytes (default: generated)",
            "teacher": "a built-in policy (one of teachers): every observation but the last then carries its move (teacher), with the nearest discrete action",
            "probe": "forecast (default none): the instructions ask every reply for a forecast (as eval --probe forecast), a reply's unreadable forecast is listed in probe_errors, and the terminal grades carry its scores (forecast)",
        },
        "teachers": crate::policy::PolicyKind::ALL.map(crate::policy::PolicyKind::name),
        "reward": REWARD,
        "feature_names": feature_names(),
        "discrete_actions": discrete_actions_json(),
    })
}

/// `GET /openapi.json`: the HTTP API.
pub(crate) fn openapi() -> Value {
    let body = |schema: Value| json!({"required": true, "content": {"application/json": {"schema": schema}}});
    let ok = |description: &str, schema: Value| json!({"200": {"description": description, "content": {"application/json": {"schema": schema}}}});
    let step_result = json!({
        "type": "object",
        "properties": {
            "observation": {"$ref": "#/components/schemas/Observation"},
            "reward": {"type": ["number", "null"]},
            "done": {"type": "boolean"},
            "metadata": {"type": "object"},
        },
        "required": ["observation", "done"],
    });
    let reset_body = json!({
        "type": "object",
        "properties": {
            "scenario": {"type": "string", "enum": ScenarioKind::ALL.iter().map(|k| k.name()).collect::<Vec<_>>()},
            "tier": {"type": "integer", "minimum": 1, "maximum": 3},
            "seed": {"type": "integer", "minimum": 0},
            "view": {"type": "string", "enum": super::session::View::NAMES},
            "episode_id": {"type": "string", "maxLength": 255},
            "teacher": {"type": "string", "enum": crate::policy::PolicyKind::ALL.map(crate::policy::PolicyKind::name)},
            "probe": {"type": "string", "enum": ["none", "forecast"]},
        },
    });
    let step_body = json!({
        "type": "object",
        "properties": {
            "action": {"$ref": "#/components/schemas/Action"},
            "episode_id": {"type": "string", "description": "The episode /reset returned (HTTP episodes only; the WebSocket session needs none)."},
            "timeout_s": {"type": "number"},
            "request_id": {"type": "string"},
        },
        "required": ["action", "episode_id"],
    });
    json!({
        "openapi": "3.1.0",
        "info": {
            "title": "negotiator env-server (OpenEnv environment HTTP API)",
            "version": OPENENV_API_VERSION,
            "description": format!("{DESCRIPTION} negotiator {}. Sessions: one per WebSocket connection on /ws; over \
                HTTP, /reset opens an episode addressed by its episode_id.", env!("CARGO_PKG_VERSION")),
        },
        "paths": {
            "/reset": {"post": {"summary": "Start an episode", "requestBody": {"required": false, "content": {"application/json": {"schema": reset_body}}}, "responses": ok("The first observation", step_result.clone())}},
            "/step": {"post": {"summary": "Apply one decision", "requestBody": body(step_body), "responses": ok("The next observation", step_result)}},
            "/state": {"get": {"summary": "The episode's state", "parameters": [{"name": "episode_id", "in": "query", "required": false, "schema": {"type": "string"}}], "responses": ok("The state", json!({"$ref": "#/components/schemas/State"}))}},
            "/schema": {"get": {"summary": "JSON schemas of the action, observation and state", "responses": ok("The schemas", json!({"type": "object"}))}},
            "/metadata": {"get": {"summary": "The environment's metadata", "responses": ok("The metadata", json!({"type": "object"}))}},
            "/health": {"get": {"summary": "Health check", "responses": ok("Healthy", json!({"type": "object", "properties": {"status": {"type": "string"}}}))}},
            "/mcp": {"post": {"summary": "MCP JSON-RPC (this environment has no tools)", "responses": ok("A JSON-RPC response", json!({"type": "object"}))}},
            "/ws": {"get": {"summary": "WebSocket session: reset, step, state and close messages", "responses": {"101": {"description": "Switching protocols"}}}},
            "/ws/batch": {"get": {"summary": "WebSocket batch of up to 64 sessions (not OpenEnv's): {\"type\": \"batch\", \"data\": [message or null per session]} answered with each session's answer", "responses": {"101": {"description": "Switching protocols"}}}},
        },
        // The full observation and state schemas are on /schema (JSON
        // Schema 2020-12, with their own $defs).
        "components": {"schemas": {
            "Action": action_schema(),
            "Observation": {"type": "object", "description": "See GET /schema (observation)."},
            "State": {"type": "object", "description": "See GET /schema (state)."},
        }},
    })
}
