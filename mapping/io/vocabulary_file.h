#pragma once
// Vocabulary files: the bag-of-binary-words vocabulary (slam/bow/vocabulary.h) that
// relocalization and loop closing use, read from disk.
//
// The repository ships one vocabulary, slam/bow/vocabulary/orb_synth.lcvoc, trained on the
// project's own synthetic renders (slam/bow/vocabulary/README.md documents the source, the
// parameters and the measured quality; scripts/train_vocabulary.sh reproduces it). Real footage
// is better served by a vocabulary trained on similar images (`lcv vocab train`).
//
// Thread safety: the functions are reentrant; the returned vocabulary is immutable and may be
// shared by any number of threads.

#include <memory>
#include <string>

#include "slam/bow/vocabulary.h"

namespace lcv::mapping {

// Reads a file written by `lcv vocab train` (Vocabulary::Save). Throws lcv::InputError whose
// message starts with the path on a missing or unreadable file, a wrong magic or version, a
// truncated file, a bad checksum or an inconsistent tree, and on a file holding no words
// (a vocabulary without words cannot recognize places). Never returns null.
std::shared_ptr<const slam::Vocabulary> ReadVocabularyFile(const std::string& path);

// The vocabulary to use when none is given: the value of the environment variable
// LCV_VOCABULARY when it is set and not empty, else the absolute path of the shipped
// slam/bow/vocabulary/orb_synth.lcvoc in the source tree this program was built from
// (compiled in; a relocated installation sets LCV_VOCABULARY). The file is not checked here.
std::string DefaultVocabularyPath();

}  // namespace lcv::mapping
