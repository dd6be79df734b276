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
// Thread safety: each call concerns the calling thread only.

#include <string>

namespace lcv::slam {

// Adds nice_increment (0..19; larger = lower priority) to the calling thread's nice value,
// clamped to 19. Returns false and sets *error (when not null) if the system refused or does
// not support per-thread priorities; 0 is a no-op that returns true.
bool LowerCurrentThreadPriority(int nice_increment, std::string* error = nullptr);

// The calling thread's nice value (Linux), or 0 where per-thread priorities are not supported.
int CurrentThreadNice();

}  // namespace lcv::slam
