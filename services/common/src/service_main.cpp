#include "mfot/service/service_main.hpp"

#include "mfot/service/config.hpp"

#include <spdlog/spdlog.h>

namespace mfot::service {

int run_service_main(const std::function<int()>& body) {
  try {
    return body();
  } catch (const ConfigError& e) {
    spdlog::error("configuration refused: {}", e.what());
    return kExitConfigRefused;
  } catch (const OutputError& e) {
    spdlog::error("output failed: {}", e.what());
    return kExitOutputFailed;
  } catch (const std::exception& e) {
    spdlog::error("fatal: {}", e.what());
    return 1;
  }
}

}  // namespace mfot::service
