#pragma once
// `lcv slam --realtime`: a dataset played as a live camera (docs/slam.md "Threads").

#include <cstddef>
#include <functional>

#include <opencv2/core.hpp>

#include "mapping/io/dataset.h"

namespace lcv::apps {

// A thread delivers each image of the dataset at its timestamp (relative to the first) into a
// slot of one frame (slam/util/bounded_queue.h); the caller's thread runs track(index, image)
// on what it finds there. When tracking is still busy when the next image is due, the waiting
// image is replaced (dropped): tracking always gets the newest image, nothing queues up.
// Returns the number of images dropped. Errors of the camera thread (an unreadable image) are
// rethrown here, after the thread is joined; so are track's.
// camera_nice: the camera thread's priority below the caller's (a nice increment, 0..19,
// slam/util/thread_priority.h). A real camera hands over decoded images; this stand-in decodes
// them from files, work that must not take the core from tracking (lcv slam passes the engine's
// SystemOptions::background_nice). Not applied where the system refuses it.
int RunLiveCamera(const mapping::Dataset& dataset,
                  const std::function<void(std::size_t, const cv::Mat&)>& track,
                  int camera_nice = 0);

}  // namespace lcv::apps
