//! MCP over JSON-RPC 2.0 (`POST /mcp`, and the WebSocket's `mcp` message):
//! this environment exposes no tools, and says so as MCP clients expect.

use super::EnvServerState;
use super::http::read_body;
use axum::extract::State;
use axum::response::{IntoResponse, Response};
use serde_json::{Value, json};
use std::sync::Arc;

/// The JSON-RPC answer to one request.
pub(super) fn mcp_response(request: &Value) -> Value {
    let id = request.get("id").cloned().unwrap_or(Value::Null);
    let error =
        |code: i64, message: &str| json!({"jsonrpc": "2.0", "id": id, "error": {"code": code, "message": message}});
    let valid = request.get("jsonrpc").and_then(Value::as_str) == Some("2.0");
    match (valid, request.get("method").and_then(Value::as_str)) {
        (true, Some("tools/list")) => json!({"jsonrpc": "2.0", "id": id, "result": {"tools": []}}),
        (true, Some(_)) => error(-32601, "Method not found: this environment has no MCP tools"),
        _ => error(-32600, "Invalid Request"),
    }
}

pub(super) async fn http_mcp(State(state): State<Arc<EnvServerState>>, body: axum::body::Body) -> Response {
    let body = match read_body(&state, body).await {
        Ok(b) => b,
        Err(r) => return r,
    };
    let reply = match serde_json::from_slice::<Value>(&body) {
        Ok(request) => mcp_response(&request),
        Err(_) => json!({"jsonrpc": "2.0", "id": null, "error": {"code": -32700, "message": "Parse error"}}),
    };
    axum::Json(reply).into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mcp_answers_json_rpc_with_no_tools() {
        assert_eq!(mcp_response(&json!({}))["error"]["code"], -32600);
        assert_eq!(
            mcp_response(&json!({"jsonrpc": "2.0", "method": "tools/list", "id": 1}))["result"]["tools"],
            json!([])
        );
        assert_eq!(mcp_response(&json!({"jsonrpc": "2.0", "method": "tools/call", "id": 2}))["error"]["code"], -32601);
    }
}
