#pragma once
// The group's identity and key from the config (group.id, group.key_file, group.max_message_age_s in
// configs/default.yaml), installed as this process's MessageAuthenticator.

#include <yaml-cpp/yaml.h>

namespace mfot::service {

// Reads the keys (throws ConfigError naming a bad one, or a key file that others may read or that is
// too short), builds the authenticator with this process as sender and installs it.
void install_group_security(const YAML::Node& root);

}  // namespace mfot::service
