#include "mfot/service/group_security.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "mfot/service/config.hpp"
#include "mfot/service/lcm_util.hpp"
#include "mfot/service/message_authenticator.hpp"
#include "mfot/service/options.hpp"

namespace mfot::service {

void install_group_security(const YAML::Node& root) {
  // The group section is mfot-run's; the services read only these keys of it (no finish()).
  auto group = config_section(root, "group");
  const auto id = read_option<long long>(group, "id");
  const auto key_file = read_option<std::string>(group, "key_file");
  const double max_age_s = read_option<double>(group, "max_message_age_s");
  std::vector<std::uint8_t> key;
  if (!key_file.empty()) key = load_group_key(key_file);
  // The sender: this process, positive.
  const std::int64_t sender = std::max<std::int64_t>(1, process_instance() & std::numeric_limits<std::int64_t>::max());
  auto authenticator = std::make_shared<MessageAuthenticator>(id, sender, std::move(key));
  authenticator->set_max_age_us(static_cast<std::int64_t>(std::llround(max_age_s * 1e6)));
  spdlog::info("group {}: {}", id,
               key_file.empty() ? "no key (group.key_file): other groups' traffic is ignored, nothing is authenticated"
                                : "messages authenticated with the key in " + key_file);
  install_message_authenticator(std::move(authenticator));
}

}  // namespace mfot::service
