#pragma once
// The common ending of every service's main: a refused configuration exits with 2, any other
// failure with 1, each logged with its reason.

#include <functional>

namespace mfot::service {

int run_service_main(const std::function<int()>& body);

}  // namespace mfot::service
