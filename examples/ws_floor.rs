//! The floor under `env-server`'s CPU per step on its own stack (axum's
//! WebSocket on tokio, one JSON text message each way): a server that
//! answers every message with a fixed observation-shaped reply of a given
//! size and does nothing else. Driven by `examples/ws_load.rs` like
//! `env-server`, its CPU per step is what the protocol, the WebSocket
//! library and the kernel cost before any environment work.
//! `cargo run --release --example ws_floor -- PORT [REPLY_BYTES, default 514]`
use axum::Router;
use axum::extract::ws::{Message, WebSocketUpgrade};
use axum::routing::get;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let port: u16 = a.get(1).and_then(|p| p.parse().ok()).unwrap_or(8000);
    let size: usize = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(514);
    let head = r#"{"type":"observation","data":{"done":false,"pad":""#;
    let tail = r#""}}"#;
    let reply = format!("{head}{}{tail}", "x".repeat(size.saturating_sub(head.len() + tail.len())));
    let app = Router::new().route(
        "/ws",
        get(move |ws: WebSocketUpgrade| {
            let reply = reply.clone();
            async move {
                // The buffers env-server gives a session.
                ws.read_buffer_size(8 * 1024).write_buffer_size(8 * 1024).on_upgrade(move |mut socket| async move {
                    while let Some(Ok(message)) = socket.recv().await {
                        if let Message::Text(_) = message
                            && socket.send(Message::Text(reply.clone().into())).await.is_err()
                        {
                            return;
                        }
                    }
                })
            }
        }),
    );
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap();
    runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind(("127.0.0.1", port)).await.unwrap();
        axum::serve(listener, app).await.unwrap();
    });
}
