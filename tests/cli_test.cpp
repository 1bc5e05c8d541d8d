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

TEST(Cli, ParsesByteSizes) {
  EXPECT_EQ(tools::parseByteSize("2G"), uint64_t(2) << 30);
  EXPECT_EQ(tools::parseByteSize("512m"), uint64_t(512) << 20);
  EXPECT_EQ(tools::parseByteSize("1.5G"), uint64_t(3) << 29);
  for (const char* bad : {"", "G", "0.5K", "-1G", "1e99T", "12X", "nan"}) EXPECT_THROW(tools::parseByteSize(bad), Error) << bad;
}

}  // namespace
}  // namespace cpvs
