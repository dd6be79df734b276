#pragma once
// Scheduling priority of the engine's own threads (issue 14; docs/slam.md "Threads"). Tracking
// must answer every camera frame within its period; local mapping, loop closing and global BA
// only have to keep up on average. As real-time systems do, the background threads run at a
// lower priority than the tracking thread, so that on a loaded machine (fewer cores than busy
// threads) the scheduler hands the core to tracking as soon as a frame arrives instead of
// sharing it evenly with them. Measured: docs/benchmarks-slam.md "Threads".
//
// Linux gives each thread its own nice value (setpriority(PRIO_PROCESS, thread id)); a thread
// inherits its creator's, so a background thread lowers its own at its start, and threads it
// creates (Ceres, OpenCV pools first used there) follow. Raising a nice value needs no
// privilege; lowering it again does (CAP_SYS_NICE), so the increments are applied once, never
// undone. Elsewhere the calls fail with a message and change nothing.
//
// A live camera's tracking thread can go further (`lcv slam --realtime --tracking-rt-priority`):
// real-time scheduling (SCHED_FIFO), as robot perception and control threads use. Measured on
// this 2-core machine (docs/benchmarks-slam.md "Threads"): with nice levels alone, the Linux
// scheduler (EEVDF since 6.6) still lets a background thread finish its time slice before a
// woken tracking thread runs, which cost the slowest 1% of frames 4-5 ms of waiting; a SCHED_FIFO
// thread takes the core at once. A real-time thread that never blocked would starve the normal
// ones on its core, so only a thread that waits for its input (a camera frame) should use it;
// the kernel's real-time throttling (sched_rt_runtime_us) is the last guard. Threads inherit the
// policy of their creator: LowerCurrentThreadPriority first returns a background thread created
// by a real-time one to normal scheduling.
//
// Thread safety: each call concerns the calling thread only.

#include <string>

namespace lcv::slam {

// Adds nice_increment (0..19; larger = lower priority) to the calling thread's nice value,
// clamped to 19. Returns false and sets *error (when not null) if the system refused or does
// not support per-thread priorities; 0 is a no-op that returns true.
bool LowerCurrentThreadPriority(int nice_increment, std::string* error = nullptr);

// Puts the calling thread under SCHED_FIFO at fifo_priority (1..99). Needs CAP_SYS_NICE or an
// RLIMIT_RTPRIO of at least fifo_priority: returns false and sets *error (when not null) if the
// system refuses, leaving the thread as it was.
bool UseRealtimeScheduling(int fifo_priority, std::string* error = nullptr);

// Returns the calling thread to normal scheduling (SCHED_OTHER), keeping its nice value; true if
// it was already there. Leaving a real-time policy needs no privilege.
bool UseNormalScheduling(std::string* error = nullptr);

// The calling thread's SCHED_FIFO / SCHED_RR priority, or 0 under normal scheduling (and where
// per-thread policies are not supported).
int CurrentThreadRealtimePriority();

// The calling thread's nice value (Linux), or 0 where per-thread priorities are not supported.
int CurrentThreadNice();

}  // namespace lcv::slam
