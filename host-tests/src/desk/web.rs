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
use super::store::{Machine, Store};
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

/// A body of content type `ty`, or the error.
fn typed<B: IntoResponse>(ty: &'static str, r: Result<B, String>) -> Response {
    match r {
        Ok(body) => ([(header::CONTENT_TYPE, ty)], body).into_response(),
        Err(e) => bad(e),
    }
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
        .route("/api/tests/stop", post(stop_test))
        .route("/api/program", post(program))
        .route("/api/live", get(live))
        .route("/api/runs", get(runs))
        .route("/api/runs/{id}", get(run))
        .route("/api/runs/{id}/stream", get(stream))
        .route("/api/trend.svg", get(trend))
        .route("/api/overlay.svg", get(overlay))
        .route("/api/export.json", get(export_json))
        .route("/api/export.csv", get(export_csv))
        // a recorded stream is ~2.5 MB a minute of runs at 1 kHz: axum's 2 MB default would
        // refuse a circle pair
        .route(
            "/api/import",
            post(import).layer(axum::extract::DefaultBodyLimit::max(512 << 20)),
        )
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
    Json(json!({ "identity": d.identity })).into_response()
}

async fn catalogue() -> Response {
    let names: Vec<_> = ballpod::app::ResultId::ALL
        .iter()
        .map(|r| json!({ "name": r.info().name, "unit": r.info().unit.as_str() }))
        .collect();
    Json(names).into_response()
}

/// Runs `f` on the store off the async workers (its clients block).
async fn db<R: Send + 'static>(
    d: &Arc<Desk>,
    f: impl FnOnce(&mut Store) -> Result<R, String> + Send + 'static,
) -> Result<R, String> {
    let store = d.store.clone();
    tokio::task::spawn_blocking(move || store.call(f))
        .await
        .unwrap_or_else(|e| Err(e.to_string()))
}

async fn machines(State(d): Shared) -> Response {
    answer(db(&d, |s| s.machines()).await)
}

async fn add_machine(State(d): Shared, Json(m): Json<serde_json::Value>) -> Response {
    let r = match serde_json::from_value::<Machine>(m) {
        Ok(m) => db(&d, move |s| s.add_machine(&m)).await,
        Err(e) => Err(format!("machine: {e}")),
    };
    answer(r.map(|id| json!({ "id": id })))
}

async fn tolerances(State(d): Shared, Path(id): Path<i64>) -> Response {
    answer(db(&d, move |s| s.tolerances(id)).await)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ToleranceIn {
    figure: String,
    #[serde(default)]
    lower: Option<f64>,
    #[serde(default)]
    upper: Option<f64>,
}

async fn set_tolerance(
    State(d): Shared,
    Path(id): Path<i64>,
    Json(t): Json<serde_json::Value>,
) -> Response {
    let r = match serde_json::from_value::<ToleranceIn>(t) {
        Ok(t) => {
            let tol = Tolerance {
                lower: t.lower,
                upper: t.upper,
            };
            db(&d, move |s| s.set_tolerance(id, &t.figure, tol)).await
        }
        Err(e) => Err(format!("tolerance: {e}")),
    };
    answer(r.map(|()| json!({})))
}

async fn start_test(State(d): Shared, Json(req): Json<serde_json::Value>) -> Response {
    let r = match serde_json::from_value::<TestRequest>(req) {
        Ok(req) => {
            let d = d.clone();
            tokio::task::spawn_blocking(move || super::tests::start(&d, req))
                .await
                .unwrap_or_else(|e| Err(e.to_string()))
        }
        Err(e) => Err(format!("test request: {e}")),
    };
    answer(r.map(|test| json!({ "test": test })))
}

async fn stop_test(State(d): Shared) -> Response {
    answer(super::tests::stop(&d).map(|test| json!({ "test": test })))
}

#[derive(Deserialize)]
struct ProgramQuery {
    #[serde(default)]
    dialect: Option<String>,
}

/// The part program of a test request (text), for the control: `?dialect=linuxcnc` (default)
/// or `fanuc`.
async fn program(Query(q): Query<ProgramQuery>, Json(req): Json<serde_json::Value>) -> Response {
    let dialect = match q.dialect.as_deref() {
        None | Some("linuxcnc") => crate::ncgen::Dialect::LinuxCnc,
        Some("fanuc") => crate::ncgen::Dialect::Fanuc,
        Some(d) => return bad(format!("dialect {d:?} is not one of linuxcnc, fanuc")),
    };
    typed(
        "text/plain; charset=utf-8",
        serde_json::from_value::<TestRequest>(req)
            .map_err(|e| format!("test request: {e}"))
            .and_then(|r| super::tests::part_program(&r, dialect)),
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
    let spooled = d.spool.waiting().len();
    Json(
        json!({ "test": l.test, "run_id": l.run_id, "step": l.step, "finished": l.finished,
                 "spooled": spooled, "trace": t }),
    )
    .into_response()
}

#[derive(Deserialize)]
struct RunsQuery {
    machine: Option<i64>,
}

async fn runs(State(d): Shared, Query(q): Query<RunsQuery>) -> Response {
    answer(db(&d, move |s| s.runs(q.machine)).await)
}

async fn run(State(d): Shared, Path(id): Path<i64>) -> Response {
    answer(db(&d, move |s| report::view(s, id)).await)
}

async fn stream(State(d): Shared, Path(id): Path<i64>) -> Response {
    typed(
        "application/octet-stream",
        db(&d, move |s| s.stream(id)).await,
    )
}

#[derive(Deserialize)]
struct TrendQuery {
    machine: i64,
    figure: String,
}

async fn trend(State(d): Shared, Query(q): Query<TrendQuery>) -> Response {
    let r = db(&d, move |s| {
        let points = report::trend(s, q.machine, &q.figure)?;
        let tol = s.tolerances(q.machine)?.get(&q.figure).copied();
        let unit = ballpod::app::ResultId::ALL
            .iter()
            .find(|r| r.info().name == q.figure)
            .map_or("", |r| r.info().unit.as_str());
        Ok(report::trend_svg(&points, tol, &q.figure, unit))
    })
    .await;
    typed("image/svg+xml", r)
}

#[derive(Deserialize)]
struct OverlayQuery {
    /// Run ids, comma-separated.
    runs: String,
}

async fn overlay(State(d): Shared, Query(q): Query<OverlayQuery>) -> Response {
    let ids: Result<Vec<i64>, String> = q
        .runs
        .split(',')
        .map(|x| {
            x.trim()
                .parse()
                .map_err(|_| format!("runs: {x:?} is not a run id"))
        })
        .collect();
    let r = match ids {
        Ok(ids) if (1..=4).contains(&ids.len()) => {
            db(&d, move |s| report::overlay_svg(s, &ids)).await
        }
        Ok(_) => Err("runs: one to four run ids".into()),
        Err(e) => Err(e),
    };
    typed("image/svg+xml", r)
}

#[derive(Deserialize)]
struct MachineQuery {
    machine: i64,
}

async fn export_json(State(d): Shared, Query(q): Query<MachineQuery>) -> Response {
    answer(db(&d, move |s| super::exchange::export_json(s, q.machine)).await)
}

async fn export_csv(State(d): Shared, Query(q): Query<MachineQuery>) -> Response {
    typed(
        "text/csv; charset=utf-8",
        db(&d, move |s| super::exchange::export_csv(s, q.machine)).await,
    )
}

#[derive(Deserialize)]
struct ImportQuery {
    machine: i64,
    operator: String,
    /// The file's name (for messages and the run's note).
    name: String,
}

/// Imports the body (a recorded stream, a `DATA:LOG?` download or a `results.json`) as a run.
async fn import(
    State(d): Shared,
    Query(q): Query<ImportQuery>,
    body: axum::body::Bytes,
) -> Response {
    let r = db(&d, move |s| {
        super::exchange::import(s, q.machine, &q.operator, &q.name, &body)
    })
    .await;
    answer(r.map(|id| json!({ "run_id": id })))
}

async fn report_page(State(d): Shared, Path(id): Path<i64>) -> Response {
    match db(&d, move |s| report::html(s, id)).await {
        Ok(h) => Html(h).into_response(),
        Err(e) => bad(e),
    }
}
