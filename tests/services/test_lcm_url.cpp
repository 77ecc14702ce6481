// The LCM URL every C++ service and client takes: the command line, then the process group's
// $MFOT_LCM_URL, then LCM's own $LCM_DEFAULT_URL, then host-local multicast.

#include <gtest/gtest.h>

#include <cstdlib>
#include <optional>
#include <string>

#include "mfot/service/lcm_util.hpp"

namespace mfot::service {
namespace {

class SavedEnvironment {
 public:
  explicit SavedEnvironment(const char* name) : name_(name) {
    if (const char* value = std::getenv(name)) saved_ = value;
    unsetenv(name);
  }
  ~SavedEnvironment() {
    if (saved_) {
      setenv(name_, saved_->c_str(), 1);
    } else {
      unsetenv(name_);
    }
  }
  SavedEnvironment(const SavedEnvironment&) = delete;
  SavedEnvironment& operator=(const SavedEnvironment&) = delete;

 private:
  const char* name_;
  std::optional<std::string> saved_;
};

TEST(LcmUrl, TheCommandLineThenTheGroupsThenLcmsThenHostLocal) {
  const SavedEnvironment group("MFOT_LCM_URL");
  const SavedEnvironment lcm("LCM_DEFAULT_URL");
  EXPECT_EQ(lcm_url(""), kDefaultLcmUrl);
  setenv("LCM_DEFAULT_URL", "udpm://239.1.2.3:9000?ttl=1", 1);
  EXPECT_EQ(lcm_url(""), "udpm://239.1.2.3:9000?ttl=1");
  setenv("MFOT_LCM_URL", "udpm://239.4.5.6:9001?ttl=1", 1);
  EXPECT_EQ(lcm_url(""), "udpm://239.4.5.6:9001?ttl=1");
  EXPECT_EQ(lcm_url("udpm://239.9.9.9:1234"), "udpm://239.9.9.9:1234");
}

TEST(LcmUrl, HostNameAndProcessInstanceAreStable) {
  EXPECT_FALSE(host_name().empty());
  EXPECT_EQ(process_instance(), process_instance());
  EXPECT_NE(process_instance(), 0);
}

}  // namespace
}  // namespace mfot::service
