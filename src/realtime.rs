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
