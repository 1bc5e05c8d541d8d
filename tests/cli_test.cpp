// The option parsing every tool shares (tools/common/cli.h).
#include <gtest/gtest.h>

#include "libcpvs/base/error.h"
#include "tools/common/cli.h"

namespace cpvs {
namespace {

TEST(Cli, ParsesResolutions) {
  EXPECT_EQ(tools::parseResolution("4k"), 4096u);
  EXPECT_EQ(tools::parseResolution("64K"), 65536u);
  EXPECT_EQ(tools::parseResolution("512"), 512u);
  for (const char* bad : {"3000", "0", "-4k", "4kk", "", "1k5", "1024k", "nan"}) EXPECT_THROW(tools::parseResolution(bad), Error);
}

}  // namespace
}  // namespace cpvs
