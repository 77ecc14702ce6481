// Fuzz target: the TUM RGB-D folder reader (TumDatasetReader), as capture uses it for
// `source: tum`. Each input replaces one file of a small valid folder; the first byte picks which:
//   0 rgb.txt, 1 depth.txt, 2 intrinsics.txt, 3 the colour PNG, 4 the depth PNG
// (values above 4 wrap). The other files keep their valid content, so the fuzzer explores one
// parser at a time from a working baseline.
// Contract checked: the reader either throws DatasetError, or lists entries whose frames read()
// returns as nullopt (with a warning) or as frames that pass Frame::validate(). List lines may
// name any path; only entries naming this folder's two images are read, so an input can never
// make the target open /dev/stdin or similar.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "mfot/service/image_io.hpp"
#include "mfot/service/tum_dataset.hpp"

namespace {

constexpr const char* kFileNames[] = {"rgb.txt", "depth.txt", "intrinsics.txt", "rgb.png", "depth.png"};
constexpr std::size_t kFileCount = std::size(kFileNames);
constexpr std::size_t kMaxEntriesRead = 4;

// The valid folder: one 3x2 frame at t = 1.0 s.
std::array<std::string, kFileCount> baseline_files() {
  using namespace mfot::service;
  const ImageRgb rgb{3, 2, {{10, 20, 30}, {40, 50, 60}, {70, 80, 90}, {1, 2, 3}, {4, 5, 6}, {7, 8, 9}}};
  const Image16 depth{3, 2, {0, 5000, 5001, 65535, 1, 2500}};
  const auto rgb_png = encode_png_rgb(rgb);
  const auto depth_png = encode_png16(depth);
  return {"# colour\n1.000000 rgb.png\n", "# depth\n1.000000 depth.png\n", "525 525 1 0.5\n",
          std::string(rgb_png.begin(), rgb_png.end()), std::string(depth_png.begin(), depth_png.end())};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mfot::service;
  mfot::fuzz::silence_logging();
  static const std::array<std::string, kFileCount> baseline = baseline_files();
  if (size == 0) return 0;
  const std::size_t replaced = data[0] % kFileCount;
  const auto& folder = mfot::fuzz::scratch_folder();
  for (std::size_t i = 0; i < kFileCount; ++i) {
    if (i == replaced) {
      mfot::fuzz::write_file(folder / kFileNames[i], data + 1, size - 1);
    } else {
      mfot::fuzz::write_file(folder / kFileNames[i], baseline[i]);
    }
  }

  TumReaderOptions options;
  options.folder = folder.string();
  std::optional<TumDatasetReader> reader;
  try {
    reader.emplace(options);
  } catch (const DatasetError&) {
    return 0;
  }
  MFOT_FUZZ_CHECK(reader->size() > 0);
  const std::string rgb_path = (folder / "rgb.png").string();
  const std::string depth_path = (folder / "depth.png").string();
  std::size_t read = 0;
  for (std::size_t i = 0; i < reader->size() && read < kMaxEntriesRead; ++i) {
    const TumEntry& entry = reader->entry(i);
    if (entry.rgb_path != rgb_path || entry.depth_path != depth_path) continue;
    ++read;
    const std::size_t warnings_before = reader->warnings().size();
    const std::optional<Frame> frame = reader->read(i);
    if (!frame) {
      MFOT_FUZZ_CHECK(reader->warnings().size() > warnings_before);
      continue;
    }
    try {
      frame->validate();
    } catch (const FrameCodecError&) {
      mfot::fuzz::fail("TumDatasetReader::read returned a frame that fails Frame::validate()");
    }
  }
  return 0;
}
