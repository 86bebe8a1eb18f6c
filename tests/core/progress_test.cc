// core/progress: the progress line, as printed to a stderr that is not a terminal.
#include "core/progress.h"

#include <catch2/catch.hpp>

#include "tests/fixture.h"

TEST_CASE("Progress prints one final line with count, percentage and unit", "[core][progress]") {
  bidex::test::CaptureOutput capture;  // stderr is a file here: plain lines, no redraws
  {
    bidex::Progress bar("soak", 1000, "slot-steps");
    for (int i = 1; i <= 1000; ++i) bar.update(i);  // no line before 10 s
    bar.finish();
    bar.finish();  // a second finish draws nothing
  }                // nor does the destructor
  std::string out = capture.text();
  INFO(out);
  CHECK(std::count(out.begin(), out.end(), '\n') == 1);
  CHECK(out.rfind("soak [############################] 100% 1.0k/1.0k slot-steps ", 0) == 0);
  CHECK(out.find('\r') == std::string::npos);
  CHECK(out.find("eta 00:00\n") != std::string::npos);
}

TEST_CASE("Progress finishes from its destructor at the count reached", "[core][progress]") {
  bidex::test::CaptureOutput capture;
  {
    bidex::Progress bar("bench", 2000000, "steps");
    bar.update(500000);
  }
  std::string out = capture.text();
  INFO(out);
  CHECK(std::count(out.begin(), out.end(), '\n') == 1);
  CHECK(out.find("bench [#######.....................]  25% 500.0k/2.00M steps") == 0);
}
