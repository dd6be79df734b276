#pragma once
// `lcv slam --realtime`: a dataset played as a live camera (docs/slam.md "Threads").

#include <cstddef>
#include <functional>
#include <string>

#include <opencv2/core.hpp>

#include "mapping/io/dataset.h"

namespace lcv::apps {

struct LiveCameraOptions {
  // The camera thread's priority below the caller's (a nice increment, 0..19,
  // slam/util/thread_priority.h). A real camera hands over decoded images; this stand-in decodes
  // them from files, work that must not take the core from tracking (lcv slam passes the
  // engine's SystemOptions::background_nice). Not applied where the system refuses it.
  int camera_nice = 0;
  // > 0: the caller's (tracking) thread runs under SCHED_FIFO at this priority (1..99) while
  // frames arrive, and goes back to normal scheduling when the camera stops. It blocks between
  // frames, so it takes a core only for the frame's work. While it falls behind the camera (a
  // frame dropped) it runs under normal scheduling, until 10 frames in a row keep up: a
  // real-time thread that never blocks would starve the other threads. 0: normal scheduling.
  int tracking_rt_priority = 0;
};

struct LiveCameraRun {
  int frames_dropped = 0;
  // The real-time priority tracking ran at (0: normal scheduling), and why the system refused
  // the requested one (empty if it did not).
  int tracking_rt_priority = 0;
  std::string priority_error;
  // How often tracking fell behind the camera and left real-time scheduling for a while.
  int realtime_suspensions = 0;
};

// A thread delivers each image of the dataset at its timestamp (relative to the first) into a
// slot of one frame (slam/util/bounded_queue.h); the caller's thread runs track(index, image)
// on what it finds there. When tracking is still busy when the next image is due, the waiting
// image is replaced (dropped): tracking always gets the newest image, nothing queues up.
// Returns the number of images dropped and the scheduling tracking got. Errors of the camera
// thread (an unreadable image) are rethrown here, after the thread is joined; so are track's.
// A refused real-time priority is not an error: tracking runs under normal scheduling.
LiveCameraRun RunLiveCamera(const mapping::Dataset& dataset,
                            const std::function<void(std::size_t, const cv::Mat&)>& track,
                            const LiveCameraOptions& options = {});

}  // namespace lcv::apps
