//! The desk's HTTP server (axum on tokio: the maintained standard for a small Rust HTTP
//! service): the page, a JSON API over [`super::store`] and [`super::tests`], the reports. It
//! listens on loopback only and answers only loopback peers that name a loopback host (a page
//! elsewhere cannot reach it through a DNS name that points here).

use std::net::{Ipv4Addr, SocketAddr};
use std::sync::Arc;

use axum::Json;
use axum::Router;
use axum::extract::{ConnectInfo, Path, Query, Request, State};
use axum::http::{StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use serde::Deserialize;
use serde_json::json;

use super::decision::Tolerance;
use super::store::Machine;
use super::tests::{TestRequest, trace};
use super::{Desk, lock, report};

/// The page (HTML and its script, no external resource).
const PAGE: &str = include_str!("page.html");

type Shared = State<Arc<Desk>>;

/// An error as the API answers it: 400 (or 404) with `{"error": …}`.
fn bad(e: String) -> Response {
    let status = if e.starts_with("no ") {
        StatusCode::NOT_FOUND
    } else {
        StatusCode::BAD_REQUEST
    };
    (status, Json(json!({ "error": e }))).into_response()
}

fn answer<T: serde::Serialize>(r: Result<T, String>) -> Response {
    match r {
        Ok(v) => Json(v).into_response(),
        Err(e) => bad(e),
    }
}

/// Refuses a peer that is not on loopback, or a request naming another host.
async fn loopback_only(
    ConnectInfo(peer): ConnectInfo<SocketAddr>,
    req: Request,
    next: Next,
) -> Response {
    let host_ok = req
        .headers()
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .is_some_and(|h| {
            let name = h.rsplit_once(':').map_or(h, |(n, _)| n);
            matches!(name, "127.0.0.1" | "localhost" | "[::1]")
        });
    if !peer.ip().is_loopback() || !host_ok {
        return (StatusCode::FORBIDDEN, "the desk answers loopback only").into_response();
    }
    next.run(req).await
}

/// The routes.
pub fn router(desk: Arc<Desk>) -> Router {
    Router::new()
        .route("/", get(|| async { Html(PAGE) }))
        .route("/api/pod", get(pod))
        .route("/api/results", get(catalogue))
        .route("/api/machines", get(machines).post(add_machine))
        .route(
            "/api/machines/{id}/tolerances",
            get(tolerances).post(set_tolerance),
        )
        .route("/api/tests", post(start_test))
        .route("/api/live", get(live))
        .route("/api/runs", get(runs))
        .route("/api/runs/{id}", get(run))
        .route("/api/runs/{id}/stream", get(stream))
        .route("/api/trend.svg", get(trend))
        .route("/report/{id}", get(report_page))
        .layer(middleware::from_fn(loopback_only))
        .with_state(desk)
}

/// Serves the desk on 127.0.0.1:`port` (0: any free port); prints `{"url": …}` once listening.
pub async fn serve(desk: Arc<Desk>, port: u16) -> std::io::Result<()> {
    let listener = tokio::net::TcpListener::bind((Ipv4Addr::LOCALHOST, port)).await?;
    let addr = listener.local_addr()?;
    println!(
        "{}",
        json!({ "url": format!("http://127.0.0.1:{}/", addr.port()) })
    );
    axum::serve(
        listener,
        router(desk).into_make_service_with_connect_info::<SocketAddr>(),
    )
    .await
}

async fn pod(State(d): Shared) -> Response {
    let identity = lock(&d.pod).as_ref().map(|p| p.identity.clone());
    Json(json!({ "identity": identity })).into_response()
}

async fn catalogue() -> Response {
    let names: Vec<_> = ballpod::app::ResultId::ALL
        .iter()
        .map(|r| json!({ "name": r.info().name, "unit": r.info().unit.as_str() }))
        .collect();
    Json(names).into_response()
}

async fn machines(State(d): Shared) -> Response {
    answer(lock(&d.store).machines())
}

async fn add_machine(State(d): Shared, Json(m): Json<serde_json::Value>) -> Response {
    answer(
        serde_json::from_value::<Machine>(m)
            .map_err(|e| format!("machine: {e}"))
            .and_then(|m| lock(&d.store).add_machine(&m))
            .map(|id| json!({ "id": id })),
    )
}

async fn tolerances(State(d): Shared, Path(id): Path<i64>) -> Response {
    answer(lock(&d.store).tolerances(id))
}

#[derive(Deserialize)]
struct ToleranceIn {
    figure: String,
    #[serde(flatten)]
    tolerance: Tolerance,
}

async fn set_tolerance(
    State(d): Shared,
    Path(id): Path<i64>,
    Json(t): Json<serde_json::Value>,
) -> Response {
    answer(
        serde_json::from_value::<ToleranceIn>(t)
            .map_err(|e| format!("tolerance: {e}"))
            .and_then(|t| lock(&d.store).set_tolerance(id, &t.figure, t.tolerance))
            .map(|()| json!({})),
    )
}

async fn start_test(State(d): Shared, Json(req): Json<serde_json::Value>) -> Response {
    answer(
        serde_json::from_value::<TestRequest>(req)
            .map_err(|e| format!("test request: {e}"))
            .and_then(|req| super::tests::start(&d, req))
            .map(|id| json!({ "run_id": id })),
    )
}

async fn live(State(d): Shared) -> Response {
    let l = lock(&d.live).clone();
    let bytes = match (&d.stream, l.finished) {
        (Some(s), false) => lock(s).bytes.get(l.stream_from..).unwrap_or(&[]).to_vec(),
        _ => Vec::new(),
    };
    let t = l
        .trace
        .as_ref()
        .map(|a| trace(&bytes, a, 1440))
        .unwrap_or_default();
    Json(json!({ "run_id": l.run_id, "step": l.step, "finished": l.finished, "trace": t }))
        .into_response()
}

#[derive(Deserialize)]
struct RunsQuery {
    machine: Option<i64>,
}

async fn runs(State(d): Shared, Query(q): Query<RunsQuery>) -> Response {
    answer(lock(&d.store).runs(q.machine))
}

async fn run(State(d): Shared, Path(id): Path<i64>) -> Response {
    answer(report::view(&lock(&d.store), id))
}

async fn stream(State(d): Shared, Path(id): Path<i64>) -> Response {
    match lock(&d.store).stream(id) {
        Ok(b) => ([(header::CONTENT_TYPE, "application/octet-stream")], b).into_response(),
        Err(e) => bad(e),
    }
}

#[derive(Deserialize)]
struct TrendQuery {
    machine: i64,
    figure: String,
}

async fn trend(State(d): Shared, Query(q): Query<TrendQuery>) -> Response {
    let store = lock(&d.store);
    let r = report::trend(&store, q.machine, &q.figure).and_then(|points| {
        let tol = store.tolerances(q.machine)?.get(&q.figure).copied();
        let unit = ballpod::app::ResultId::ALL
            .iter()
            .find(|r| r.info().name == q.figure)
            .map_or("", |r| r.info().unit.as_str());
        Ok(report::trend_svg(&points, tol, &q.figure, unit))
    });
    match r {
        Ok(svg) => ([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response(),
        Err(e) => bad(e),
    }
}

async fn report_page(State(d): Shared, Path(id): Path<i64>) -> Response {
    match report::html(&lock(&d.store), id) {
        Ok(h) => Html(h).into_response(),
        Err(e) => bad(e),
    }
}
