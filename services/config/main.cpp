// mfot-config: prints what the option table (services/common/src/option_table.cpp) generates:
// configs/default.yaml (--print-defaults) and docs/options.md (--print-docs).
#include <cstring>
#include <iostream>

#include "mfot/service/options.hpp"

int main(int argc, char** argv) {
  if (argc == 2 && std::strcmp(argv[1], "--print-defaults") == 0) {
    std::cout << mfot::service::generate_default_yaml();
    return 0;
  }
  if (argc == 2 && std::strcmp(argv[1], "--print-docs") == 0) {
    std::cout << mfot::service::generate_options_markdown();
    return 0;
  }
  std::cerr << "usage: mfot-config --print-defaults | --print-docs\n"
               "  --print-defaults  configs/default.yaml as the option table generates it\n"
               "  --print-docs      docs/options.md as the option table generates it\n";
  return 2;
}
