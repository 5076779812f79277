// `minimanip report` on a real campaign (a fault campaign on mock, so every section has data),
// rendered by headless Chromium (Debian's chromium): the page lays out every plot with a size, and
// the numbers the rendered page shows equal summary.json's. Outside CI it skips, saying why, where
// Chromium is missing; with MINIMANIP_CI set (.ci/run) it may not skip.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <regex>

#include "cli_helpers.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace testing_cli;

std::string pct(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f%%", 100 * v);
  return b;
}

// The text of the element with data-key="key" in the DOM Chromium dumped.
std::string shown(const std::string& dom, const std::string& key) {
  const std::regex re("data-key=\"" + key + "\">([^<]*)<");
  std::smatch m;
  return std::regex_search(dom, m, re) ? m[1].str() : "(absent)";
}

TEST(Report, ChromiumRendersEveryPlotWithTheSummarysNumbers) {
  std::string said;
  if (shellOut("command -v chromium", said) != 0) {
    if (std::getenv("MINIMANIP_CI")) FAIL() << "under CI the report test may not skip: chromium is not installed";
    GTEST_SKIP() << "chromium is not installed (tools/setup installs it)";
  }
  TempDir d;
  const fs::path out = d.path() / "faults";
  const RunResult r = runMinimanip("run experiments/faults.yaml --trials 12 --seed 3 --set hardware=mock --set progress=none --out " +
                                   out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const RunResult rep = runMinimanip("report " + out.string());
  ASSERT_EQ(rep.code, 0) << rep.out;
  ASSERT_TRUE(fs::exists(out / "report.html"));
  ASSERT_TRUE(fs::exists(out / "report.md"));
  // Chromium loads the page, lays it out and counts the plots it drew with a size.
  const std::string dom = renderInChromium(out / "report.html", d.path());
  ASSERT_FALSE(dom.empty()) << "chromium failed";
  std::smatch m;
  ASSERT_TRUE(std::regex_search(dom, m, std::regex("data-plots-drawn=\"([0-9]+)\""))) << dom.substr(0, 2000);
  const json s = json::parse(std::ifstream(out / "summary.json"));
  // cycle histogram, stage breakdown, place scatter, fault recovery; failure stages when some failed
  EXPECT_EQ(std::stoi(m[1].str()), 4 + !s["failure_stages"].empty());
  EXPECT_EQ(shown(dom, "overall_yield"), pct(s["overall_yield"]["value"]));
  EXPECT_EQ(shown(dom, "first_pass_yield"), pct(s["first_pass_yield"]["value"]));
  EXPECT_EQ(shown(dom, "successes_of_trials"), std::to_string(s["successes"].get<long>()) + " / " + std::to_string(s["trials"].get<long>()));
  EXPECT_EQ(shown(dom, "collision_events"), std::to_string(s["collision_events"].get<long>()));
  ASSERT_FALSE(s["faults"].empty());
  for (const json& f : s["faults"])
    if (f["recovery"].get<double>() >= 0) {
      EXPECT_EQ(shown(dom, "recovery." + f["kind"].get<std::string>()), pct(f["recovery"])) << f["kind"];
    }
  // The page needs nothing from the network or the disk: no src or href to fetch.
  std::ifstream in(out / "report.html");
  const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(html.find("src="), std::string::npos);
  EXPECT_EQ(html.find("href="), std::string::npos);
}

}  // namespace
}  // namespace mm
