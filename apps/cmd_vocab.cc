// `lcv vocab train`: a bag-of-binary-words vocabulary from the ORB features of image folders.
// `lcv vocab info`: loads a vocabulary file and prints its shape and load time.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>


#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/media.h"
#include "mapping/io/vocabulary_file.h"
#include "slam/bow/vocabulary.h"
#include "slam/feature/orb_extractor.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

namespace fs = std::filesystem;

bool IsImageFile(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".pgm" || ext == ".ppm" ||
         ext == ".bmp" || ext == ".tif" || ext == ".tiff";
}

// The image files of a folder (not recursive), sorted by name.
std::vector<fs::path> ImagesIn(const std::string& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) throw InputError(folder, "not a folder");
  std::vector<fs::path> images;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_regular_file() && IsImageFile(entry.path())) images.push_back(entry.path());
  }
  if (error) throw InputError(folder, "cannot list: " + error.message());
  if (images.empty()) throw InputError(folder, "no images (.png, .jpg, .pgm, .ppm, .bmp, .tif)");
  std::sort(images.begin(), images.end());
  return images;
}

// `--images A B C` -> `--images A --images B --images C`: the folders that follow one --images up
// to the next option, so that both the issue's `--images DIR...` and repeated flags work. A
// folder whose name starts with '-' must be given as --images=-DIR.
std::vector<std::string> ExpandImageFolders(int argc, char** argv) {
  std::vector<std::string> out;
  bool after_images = false;  // the previous arguments were --images and its folders
  for (int i = 0; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--images") {
      out.push_back(arg);
      if (i + 1 < argc) out.push_back(argv[++i]);  // its own value, left to the parser
      after_images = true;
    } else if (after_images && !arg.empty() && arg[0] != '-') {
      out.push_back("--images");
      out.push_back(arg);
    } else {
      after_images = arg.rfind("--images=", 0) == 0;
      out.push_back(arg);
    }
  }
  return out;
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int RunVocabTrain(int raw_argc, char** raw_argv) {
  std::vector<std::string> expanded = ExpandImageFolders(raw_argc, raw_argv);
  std::vector<char*> expanded_argv;
  for (std::string& arg : expanded) expanded_argv.push_back(arg.data());
  const int argc = static_cast<int>(expanded_argv.size());
  char** argv = expanded_argv.data();
  ArgParser args(
      "lcv vocab train --images DIR... --out FILE [options]",
      "Trains a vocabulary tree for ORB descriptors (DBoW2-like: hierarchical k-majority\n"
      "clustering with k-means++ seeding, TF-IDF weights) on the features of every image in\n"
      "the given folders (not recursive, sorted by name), extracted with the SLAM's own ORB\n"
      "extractor. The result is a compact binary file (a few tens of MB for 10^6 words) for\n"
      "place recognition (loop detection, relocalization); `lcv vocab info` checks it.\n"
      "The repository ships one trained on its own synthetic renders\n"
      "(slam/bow/vocabulary/README.md: when to train your own, and how).",
      "lcv vocab train --images ../shared/data/kitti00/image_0 --step 10 --out kitti.lcvoc");
  args.AddOption("--images", "DIR...",
                 "folders of images (--images A B or --images A --images B)");
  args.AddOption("--out", "FILE", "vocabulary file to write (atomically)");
  args.AddOption("--branching", "K", "children per node", "10");
  args.AddOption("--depth", "L", "levels below the root (at most K^L words)", "6");
  args.AddOption("--iterations", "N", "k-majority iterations per node", "10");
  args.AddOption("--features", "N", "ORB features per image", "1000");
  args.AddOption("--step", "N", "use every N-th image of each folder", "1");
  args.AddOption("--max-images", "N", "stop after N images in total (0: no limit)", "0");
  args.AddOption("--seed", "N", "seed of the k-means++ seeding", "1");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"--out"});  // before any work

  const std::vector<std::string> folders = args.GetAll("--images");
  if (folders.empty()) throw UsageError("--images: at least one folder is required");
  const std::string out_path = args.Get("--out");
  slam::VocabularyOptions options;
  options.branching = args.GetInt("--branching");
  options.depth = args.GetInt("--depth");
  options.max_iterations = args.GetInt("--iterations");
  options.seed = args.GetSeed("--seed");
  if (const auto problem = options.Problem()) throw UsageError(*problem);
  const int step = args.GetInt("--step");
  if (step < 1) throw UsageError("--step must be >= 1");
  const int max_images = args.GetInt("--max-images");
  if (max_images < 0) throw UsageError("--max-images must be >= 0");
  slam::OrbExtractorOptions extractor_options;
  extractor_options.num_features = args.GetInt("--features");
  if (const auto problem = extractor_options.Problem()) throw UsageError("--features: " + *problem);

  std::vector<fs::path> images;
  for (const std::string& folder : folders) {
    const std::vector<fs::path> in_folder = ImagesIn(folder);
    for (std::size_t i = 0; i < in_folder.size(); i += step) images.push_back(in_folder[i]);
  }
  if (max_images > 0 && static_cast<int>(images.size()) > max_images) images.resize(max_images);

  const auto start = std::chrono::steady_clock::now();
  slam::OrbExtractor extractor(extractor_options);
  std::vector<std::vector<slam::OrbDescriptor>> descriptors(images.size());
  std::vector<slam::Keypoint> keypoints;
  std::size_t num_descriptors = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const cv::Mat image = mapping::ReadImageFile(images[i].string(), mapping::ImageMode::kGray);
    if (image.empty()) throw InputError(images[i].string(), "cannot decode the image");
    extractor.Extract(image, cv::Mat(), &keypoints, &descriptors[i]);
    num_descriptors += descriptors[i].size();
    if ((i + 1) % 100 == 0 || i + 1 == images.size()) {
      std::cerr << "lcv vocab train: features of " << i + 1 << "/" << images.size()
                << " images (" << num_descriptors << " descriptors)\n";
    }
  }
  if (num_descriptors == 0) throw InputError(folders.front(), "no ORB features in the images");
  const double extract_s = SecondsSince(start);

  std::cerr << "lcv vocab train: clustering (K=" << options.branching << ", L=" << options.depth
            << ")\n";
  const auto train_start = std::chrono::steady_clock::now();
  const slam::Vocabulary vocabulary = slam::Vocabulary::Train(descriptors, options);
  const double train_s = SecondsSince(train_start);

  std::ostringstream bytes;
  vocabulary.Save(bytes);
  mapping::WriteFileAtomically(out_path, bytes.str());
  std::cout << "vocabulary: " << vocabulary.num_words() << " words, " << vocabulary.num_nodes()
            << " nodes (K=" << options.branching << ", L=" << options.depth << ")\n"
            << "trained on: " << images.size() << " images, " << num_descriptors
            << " descriptors\n"
            << "time: features " << extract_s << " s, clustering " << train_s << " s\n"
            << "written: " << out_path << " (" << bytes.str().size() << " bytes)\n";
  return kExitOk;
}

int RunVocabInfo(int argc, char** argv) {
  ArgParser args("lcv vocab info FILE",
                 "Loads a vocabulary written by `lcv vocab train` (checking magic, version,\n"
                 "checksum and tree structure) and prints its shape, size and load time.",
                 "lcv vocab info slam/bow/vocabulary/orb_synth.lcvoc");
  args.AddPositional("FILE", "vocabulary file");
  if (!args.Parse(argc, argv)) return kExitOk;
  const std::string path = args.Positional("FILE");
  const auto start = std::chrono::steady_clock::now();
  const std::shared_ptr<const slam::Vocabulary> vocabulary = mapping::ReadVocabularyFile(path);
  const double load_s = SecondsSince(start);
  std::error_code error;
  const auto bytes = fs::file_size(path, error);
  std::size_t weighted = 0;
  for (slam::WordId w = 0; w < vocabulary->num_words(); ++w) weighted += vocabulary->WordWeight(w) > 0;
  std::cout << "vocabulary: " << vocabulary->num_words() << " words (" << weighted
            << " with idf > 0), " << vocabulary->num_nodes() << " nodes, K="
            << vocabulary->branching() << ", L=" << vocabulary->depth() << "\n";
  if (!error) std::cout << "file: " << path << " (" << bytes << " bytes)\n";
  std::cout << "loaded in: " << load_s << " s\n";
  return kExitOk;
}

}  // namespace
LCV_REGISTER_COMMAND("vocab train", "train a BoW vocabulary from image folders", RunVocabTrain);
LCV_REGISTER_COMMAND("vocab info", "load a vocabulary file and print its shape", RunVocabInfo);
}  // namespace lcv::apps
