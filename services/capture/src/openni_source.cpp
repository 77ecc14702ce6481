#include "mfot/capture/openni_source.hpp"

#include <OpenNI.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <thread>

#include "mfot/service/lcm_util.hpp"

namespace mfot::capture {
namespace {

std::string openni_error() {
  const char* text = openni::OpenNI::getExtendedError();
  return text != nullptr && *text != '\0' ? text : "no details from OpenNI2";
}

// OpenNI2 is a process-wide library; the first source initialises it.
void initialise_openni() {
  static const openni::Status status = openni::OpenNI::initialize();
  if (status != openni::STATUS_OK) throw CaptureError("cannot initialise OpenNI2: " + openni_error());
}

const openni::VideoMode* find_mode(const openni::SensorInfo* info, int width, int height, int fps,
                                   openni::PixelFormat format) {
  if (info == nullptr) return nullptr;
  const auto& modes = info->getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::VideoMode& mode = modes[i];
    if (mode.getResolutionX() == width && mode.getResolutionY() == height && mode.getFps() == fps &&
        mode.getPixelFormat() == format) {
      return &mode;
    }
  }
  return nullptr;
}

std::string list_modes(const openni::SensorInfo* info) {
  std::string text;
  if (info == nullptr) return text;
  const auto& modes = info->getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i) {
    text += (text.empty() ? "" : ", ") + std::to_string(modes[i].getResolutionX()) + "x" +
            std::to_string(modes[i].getResolutionY()) + "@" + std::to_string(modes[i].getFps()) + " format " +
            std::to_string(static_cast<int>(modes[i].getPixelFormat()));
  }
  return text;
}

}  // namespace

void OpenNiOptions::validate() const {
  const auto range = [](const char* field, double value, double lo, double hi, bool open_low) {
    if (!(std::isfinite(value) && (open_low ? value > lo : value >= lo) && value <= hi)) {
      throw std::invalid_argument(std::string("OpenNiOptions.") + field + " " + std::to_string(value) +
                                  " is out of range " + (open_low ? "(" : "[") + std::to_string(lo) + ", " +
                                  std::to_string(hi) + "]");
    }
  };
  if (file && uri.empty()) throw std::invalid_argument("OpenNiOptions.uri must name the .oni file");
  range("width", width, 1, 4096, false);
  range("height", height, 1, 4096, false);
  range("fps", fps, 1, 120, false);
  range("read_timeout_ms", read_timeout_ms, 100, 60000, false);
  range("reopen_max_backoff_s", reopen_max_backoff_s, 0.0, 600.0, true);
  range("reopen_initial_backoff_s", reopen_initial_backoff_s, 0.0, reopen_max_backoff_s, true);
}

struct OpenNiSource::Device {
  openni::Device device;
  openni::VideoStream depth;
  openni::VideoStream color;
  std::string uri;
  float fx = 0.0f, fy = 0.0f;
  int frames_in_recording = 0;  // recordings only

  ~Device() {
    depth.stop();
    color.stop();
    depth.destroy();
    color.destroy();
    device.close();
  }
};

OpenNiSource::OpenNiSource(OpenNiOptions options) : options_(std::move(options)) {
  options_.validate();
  initialise_openni();
  open();
}

OpenNiSource::~OpenNiSource() = default;

std::string OpenNiSource::name() const {
  return (options_.file ? "oni:" : "openni2:") + (uri_.empty() ? options_.uri : uri_);
}

void OpenNiSource::open() {
  auto device = std::make_unique<Device>();
  if (options_.file) {
    std::error_code error;
    if (!std::filesystem::is_regular_file(options_.uri, error)) {
      throw CaptureError(options_.uri + ": no such .oni recording");
    }
    device->uri = options_.uri;
  } else if (options_.uri.empty()) {
    openni::Array<openni::DeviceInfo> devices;
    openni::OpenNI::enumerateDevices(&devices);
    if (devices.getSize() == 0) {
      throw CaptureError(
          "no OpenNI2 device found (is the camera plugged in, powered, and readable by this user? "
          "see the udev rules of your camera driver)");
    }
    device->uri = devices[0].getUri();
  } else {
    device->uri = options_.uri;
  }
  const std::string what = options_.file ? "OpenNI2 recording " + device->uri : "OpenNI2 device " + device->uri;
  if (device->device.open(device->uri.c_str()) != openni::STATUS_OK) {
    throw CaptureError("cannot open " + what + ": " + openni_error());
  }
  if (device->depth.create(device->device, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
    throw CaptureError(what + " has no depth stream: " + openni_error());
  }
  if (device->color.create(device->device, openni::SENSOR_COLOR) != openni::STATUS_OK) {
    throw CaptureError(what + " has no colour stream: " + openni_error());
  }

  if (options_.file) {
    openni::PlaybackControl* playback = device->device.getPlaybackControl();
    if (playback == nullptr) throw CaptureError(what + ": no playback control");
    // Manual mode: each read returns the next recorded frame; pacing is the service's job.
    playback->setSpeed(-1.0f);
    playback->setRepeatEnabled(false);
    device->frames_in_recording = playback->getNumberOfFrames(device->depth);
    if (device->frames_in_recording <= 0) throw CaptureError(what + ": recording has no depth frames");
  } else {
    const openni::VideoMode* depth_mode = find_mode(device->device.getSensorInfo(openni::SENSOR_DEPTH), options_.width,
                                                    options_.height, options_.fps, openni::PIXEL_FORMAT_DEPTH_1_MM);
    const openni::VideoMode* color_mode = find_mode(device->device.getSensorInfo(openni::SENSOR_COLOR), options_.width,
                                                    options_.height, options_.fps, openni::PIXEL_FORMAT_RGB888);
    if (depth_mode == nullptr || color_mode == nullptr) {
      throw CaptureError(what + " offers no " + std::to_string(options_.width) + "x" + std::to_string(options_.height) +
                         "@" + std::to_string(options_.fps) + " depth (1 mm) and RGB888 modes; depth modes: " +
                         list_modes(device->device.getSensorInfo(openni::SENSOR_DEPTH)) +
                         "; colour modes: " + list_modes(device->device.getSensorInfo(openni::SENSOR_COLOR)));
    }
    if (device->depth.setVideoMode(*depth_mode) != openni::STATUS_OK ||
        device->color.setVideoMode(*color_mode) != openni::STATUS_OK) {
      throw CaptureError(what + ": cannot set the video modes: " + openni_error());
    }
    if (!device->device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) ||
        device->device.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) != openni::STATUS_OK) {
      throw CaptureError(what + " cannot register depth to colour: " + openni_error());
    }
    device->device.setDepthColorSyncEnabled(true);
    device->depth.setMirroringEnabled(false);
    device->color.setMirroringEnabled(false);
  }
  if (device->depth.start() != openni::STATUS_OK || device->color.start() != openni::STATUS_OK) {
    throw CaptureError(what + ": cannot start the streams: " + openni_error());
  }
  // Registered depth shares the colour camera's pinhole: focal lengths from its fields of view.
  const openni::VideoMode mode = device->color.getVideoMode();
  const float hfov = device->color.getHorizontalFieldOfView();
  const float vfov = device->color.getVerticalFieldOfView();
  if (!(hfov > 0.0f && hfov < 3.1f && vfov > 0.0f && vfov < 3.1f)) {
    throw CaptureError(what + ": invalid field of view reported by the device");
  }
  device->fx = static_cast<float>(mode.getResolutionX()) / (2.0f * std::tan(hfov / 2.0f));
  device->fy = static_cast<float>(mode.getResolutionY()) / (2.0f * std::tan(vfov / 2.0f));
  spdlog::info("opened {} ({}x{}, fx {:.1f}, fy {:.1f})", what, mode.getResolutionX(), mode.getResolutionY(),
               device->fx, device->fy);
  uri_ = device->uri;
  device_ = std::move(device);
}

std::optional<SourceFrame> OpenNiSource::read_pair(std::string& failure) {
  const auto read = [&](openni::VideoStream& stream, openni::VideoFrameRef& frame) {
    openni::VideoStream* streams[] = {&stream};
    int ready = -1;
    if (!options_.file &&
        openni::OpenNI::waitForAnyStream(streams, 1, &ready, options_.read_timeout_ms) != openni::STATUS_OK) {
      failure = "no frame within " + std::to_string(options_.read_timeout_ms) + " ms";
      return false;
    }
    if (stream.readFrame(&frame) != openni::STATUS_OK || !frame.isValid()) {
      failure = "read failed: " + openni_error();
      return false;
    }
    return true;
  };
  openni::VideoFrameRef depth, color;
  if (!read(device_->depth, depth) || !read(device_->color, color)) return std::nullopt;
  // Synchronised streams arrive together; otherwise advance the older one (a few times at most).
  const std::uint64_t half_period_us = 500000u / static_cast<std::uint64_t>(options_.fps);
  for (int attempt = 0; attempt < 3; ++attempt) {
    if (depth.getTimestamp() + half_period_us < color.getTimestamp()) {
      if (!read(device_->depth, depth)) return std::nullopt;
    } else if (color.getTimestamp() + half_period_us < depth.getTimestamp()) {
      if (!read(device_->color, color)) return std::nullopt;
    } else {
      break;
    }
  }
  const int width = depth.getWidth(), height = depth.getHeight();
  if (color.getWidth() != width || color.getHeight() != height) {
    failure = "depth is " + std::to_string(width) + "x" + std::to_string(height) + " but colour is " +
              std::to_string(color.getWidth()) + "x" + std::to_string(color.getHeight());
    return std::nullopt;
  }
  if (depth.getVideoMode().getPixelFormat() != openni::PIXEL_FORMAT_DEPTH_1_MM ||
      color.getVideoMode().getPixelFormat() != openni::PIXEL_FORMAT_RGB888) {
    failure = "unsupported pixel formats (need 1 mm depth and RGB888 colour)";
    return std::nullopt;
  }
  if (depth.getStrideInBytes() < width * 2 || color.getStrideInBytes() < width * 3) {
    failure = "frame stride smaller than its width";
    return std::nullopt;
  }
  SourceFrame out;
  out.index = next_index_;
  service::Frame& frame = out.frame;
  frame.capture_utime = options_.file ? static_cast<std::int64_t>(depth.getTimestamp()) : service::now_utime();
  frame.width = width;
  frame.height = height;
  frame.fx = device_->fx;
  frame.fy = device_->fy;
  frame.cx = static_cast<float>(width - 1) / 2.0f;
  frame.cy = static_cast<float>(height - 1) / 2.0f;
  frame.depth_mm.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  frame.color.resize(frame.depth_mm.size());
  const auto* depth_bytes = static_cast<const std::uint8_t*>(depth.getData());
  const auto* color_bytes = static_cast<const std::uint8_t*>(color.getData());
  for (int y = 0; y < height; ++y) {
    std::memcpy(frame.depth_mm.data() + static_cast<std::size_t>(y) * width,
                depth_bytes + static_cast<std::size_t>(y) * depth.getStrideInBytes(),
                static_cast<std::size_t>(width) * 2);
    std::memcpy(frame.color.data() + static_cast<std::size_t>(y) * width,
                color_bytes + static_cast<std::size_t>(y) * color.getStrideInBytes(),
                static_cast<std::size_t>(width) * 3);
  }
  return out;
}

std::optional<SourceFrame> OpenNiSource::next() {
  const auto stopping = [&] { return options_.stop_requested && options_.stop_requested(); };
  if (options_.file) {
    if (next_index_ >= device_->frames_in_recording) return std::nullopt;
    std::string failure;
    auto frame = read_pair(failure);
    if (!frame) throw CaptureError(name() + ": frame " + std::to_string(next_index_) + ": " + failure);
    ++next_index_;
    return frame;
  }
  double backoff_s = options_.reopen_initial_backoff_s;
  while (!stopping()) {
    std::string failure;
    if (device_) {
      if (auto frame = read_pair(failure)) {
        ++next_index_;
        return frame;
      }
      spdlog::warn("{}: camera lost ({}); closing it and reopening", name(), failure);
      device_.reset();
    }
    spdlog::warn("{}: reopening the camera in {:.1f} s", name(), backoff_s);
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(backoff_s);
    while (!stopping() && std::chrono::steady_clock::now() < until) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (stopping()) break;
    try {
      open();
      spdlog::info("{}: camera reopened", name());
      backoff_s = options_.reopen_initial_backoff_s;
    } catch (const CaptureError& e) {
      spdlog::warn("{}", e.what());
      backoff_s = std::min(2.0 * backoff_s, options_.reopen_max_backoff_s);
    }
  }
  return std::nullopt;
}

bool OpenNiSource::rewind() {
  if (!options_.file) return false;
  seek(0);
  return true;
}

void OpenNiSource::seek(std::int64_t index) {
  if (!options_.file) {
    FrameSource::seek(index);
    return;
  }
  if (index < 0 || index >= device_->frames_in_recording) {
    throw CaptureError(name() + ": start frame " + std::to_string(index) + " is outside [0, " +
                       std::to_string(device_->frames_in_recording) + ")");
  }
  openni::PlaybackControl* playback = device_->device.getPlaybackControl();
  if (playback->seek(device_->depth, static_cast<int>(index)) != openni::STATUS_OK) {
    throw CaptureError(name() + ": cannot seek to frame " + std::to_string(index) + ": " + openni_error());
  }
  next_index_ = index;
}

}  // namespace mfot::capture
