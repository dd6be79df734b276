#include "mapping/io/vocabulary_file.h"

#include <cstdlib>
#include <sstream>
#include <string_view>

#include "mapping/io/atomic_file.h"
#include "slam/util/error.h"

#ifndef LCV_DEFAULT_VOCABULARY_PATH
#error "LCV_DEFAULT_VOCABULARY_PATH must be defined by the build (mapping/CMakeLists.txt)"
#endif

namespace lcv::mapping {

std::shared_ptr<const slam::Vocabulary> ReadVocabularyFile(const std::string& path) {
  // One read of the whole file, then parsing from memory: much faster than many small reads
  // from an ifstream, and ReadFileBytes already reports a missing file by its path.
  // The magic is checked on the first bytes, before the rest is read: --vocabulary /dev/zero or a
  // huge unrelated file fails at once (issue 16).
  std::istringstream in(ReadFileBytesChecked(path, kMaxInputFileBytes, [&](std::string_view head) {
    if (head.substr(0, 8) != "LCVVOCAB") {
      throw InputError(path, "not a vocabulary file (magic \"LCVVOCAB\" missing)");
    }
  }));
  auto vocabulary = std::make_shared<slam::Vocabulary>(slam::Vocabulary::Load(in, path));
  if (vocabulary->empty()) throw InputError(path, "the vocabulary has no words");
  return vocabulary;
}

std::string DefaultVocabularyPath() {
  const char* from_environment = std::getenv("LCV_VOCABULARY");
  if (from_environment != nullptr && from_environment[0] != '\0') return from_environment;
  return LCV_DEFAULT_VOCABULARY_PATH;
}

}  // namespace lcv::mapping
