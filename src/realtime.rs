//! Real-time scheduling for the threads that keep a device's time (the
//! haptic loop, an emulator's loop) and a sound output's (a player's
//! thread, issue 64). A real device has a processor of
//! its own; an emulator shares the host's, and at normal priority a busy
//! machine (a build beside the tests) kept it from running for 100 ms at a
//! time: a device silent that long is a lost device, and the trial under
//! way was aborted (issue 63). At SCHED_FIFO it runs when it is due, as
//! the haptic loop does. A shell: it changes the calling thread's
//! scheduling (and a thread it then spawns inherits it).

/// Asks for SCHED_FIFO at the lowest real-time priority for the calling
/// thread; whether it was granted (a user without the right keeps the
/// normal scheduling, and everything works as before, only less punctually
/// on a busy machine).
#[must_use]
#[cfg(unix)]
pub fn ask_fifo() -> bool {
    thread_priority::set_thread_priority_and_policy(
        thread_priority::thread_native_id(),
        thread_priority::ThreadPriority::Min,
        thread_priority::ThreadSchedulePolicy::Realtime(
            thread_priority::RealtimeThreadSchedulePolicy::Fifo,
        ),
    )
    .is_ok()
}

/// The real-time priority a sound output's thread asks for: above the
/// loops' (the lowest, [`ask_fifo`]), which spin the last stretch before
/// each deadline and, at the same priority, kept a player's thread off
/// both cores long enough for the server to run dry (issue 64: beside a
/// build, 3 underruns and 2 trials aborted in a 67 s session). A
/// player's work is a few microseconds a buffer.
pub const SOUND_PRIORITY: u8 = 5;

/// As [`ask_fifo`], at priority `priority` (1 to 99 under SCHED_FIFO).
#[must_use]
#[cfg(unix)]
pub fn ask_fifo_at(priority: u8) -> bool {
    let Ok(value) = thread_priority::ThreadPriorityValue::try_from(priority) else {
        return false;
    };
    thread_priority::set_thread_priority_and_policy(
        thread_priority::thread_native_id(),
        thread_priority::ThreadPriority::Crossplatform(value),
        thread_priority::ThreadSchedulePolicy::Realtime(
            thread_priority::RealtimeThreadSchedulePolicy::Fifo,
        ),
    )
    .is_ok()
}

/// Windows has no SCHED_FIFO: the thread keeps its priority.
#[must_use]
#[cfg(not(unix))]
pub fn ask_fifo() -> bool {
    false
}

/// Windows has no SCHED_FIFO: the thread keeps its priority.
#[must_use]
#[cfg(not(unix))]
pub fn ask_fifo_at(_priority: u8) -> bool {
    false
}
