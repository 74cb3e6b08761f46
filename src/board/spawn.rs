//! Spawning the firmware's tasks on its executors, thread mode or interrupt: a task fn only
//! fails when its pool is exhausted, which a single spawn per task cannot do — logged rather
//! than panicked on all the same. Every board's.

/// Spawns the task `token` (named `name` in the log) with `spawner`.
pub fn spawn<S, E: Spawn<S>>(
    spawner: &E,
    name: &str,
    token: Result<embassy_executor::SpawnToken<S>, embassy_executor::SpawnError>,
) {
    match token {
        Ok(t) => spawner.spawn_token(t),
        Err(_) => defmt::error!("cannot spawn task {}", name),
    }
}

/// The two kinds of spawner (thread mode, interrupt executor).
pub trait Spawn<S> {
    /// Spawns the task.
    fn spawn_token(&self, t: embassy_executor::SpawnToken<S>);
}

impl<S> Spawn<S> for embassy_executor::Spawner {
    fn spawn_token(&self, t: embassy_executor::SpawnToken<S>) {
        self.spawn(t);
    }
}

impl<S: Send> Spawn<S> for embassy_executor::SendSpawner {
    fn spawn_token(&self, t: embassy_executor::SpawnToken<S>) {
        self.spawn(t);
    }
}
