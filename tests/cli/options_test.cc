// The command line itself (cli/app.cc on CLI11): typed options with their
// ranges, one-line usage errors naming the option, --version, help with an
// example for every verb, and the MESHSTREAM_* environment rule.
#include <algorithm>
#include <string>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/common/cli_util.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::Cli;
using test_util::ModelPath;
using test_util::Quote;
using test_util::RunCommand;
using test_util::TempDir;

size_t Lines(const std::string& s) { return static_cast<size_t>(std::count(s.begin(), s.end(), '\n')); }

TEST(CliOptions, VersionPrintsTheProjectVersion) {
  const auto r = RunCommand(Cli() + " --version");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out, "meshstream 0.1.0\n");
}

TEST(CliOptions, EveryVerbsHelpSaysWhatItDoesAndGivesAnExample) {
  const std::vector<const char*> verbs = {"info",   "convert",  "compare", "encode", "decode", "serve",
                                          "ingest", "versions", "assets",  "export", "token", "fetch"};
  for (const char* verb : verbs) {
    const auto r = RunCommand(Cli() + " " + verb + " --help");
    EXPECT_EQ(r.exit_code, 0) << verb;
    EXPECT_EQ(r.out.rfind(std::string("usage: meshstream ") + verb, 0), 0u) << r.out;
    const bool example = r.out.find(std::string("Example:\n  meshstream ") + verb) != std::string::npos ||
                         r.out.find(std::string("Examples:\n  meshstream ") + verb) != std::string::npos;
    EXPECT_TRUE(example) << r.out;
    EXPECT_TRUE(r.err.empty()) << r.err;
    // The top-level help lists the verb with its sentence.
  }
  const auto top = RunCommand(Cli() + " --help");
  for (const char* verb : verbs) {
    EXPECT_NE(top.out.find(std::string("  ") + verb + " "), std::string::npos) << verb << "\n" << top.out;
  }
  EXPECT_NE(top.out.find("Exit status: 0 success, 1 bad input (or refused by the server), 2 bad usage, 3 server "
                         "unreachable"),
            std::string::npos)
      << top.out;
}

// Each bad value is a usage error: exit 2, one line on stderr that names the
// option, and no output file.
TEST(CliOptions, OutOfRangeAndMistypedValuesAreOneLineUsageErrorsNamingTheOption) {
  TempDir dir;
  const std::string src = Quote(ModelPath("spot.obj"));
  const std::string out = Quote(dir.File("x.glb"));
  struct Case {
    std::string args, option;
  };
  const std::vector<Case> cases = {
      {"encode --qp 31 " + src + " -o " + out, "--qp"},
      {"encode --qp abc " + src + " -o " + out, "--qp"},
      {"encode --qn 1 " + src + " -o " + out, "--qn"},
      {"encode --packet-bytes 63 " + src + " -o " + out, "--packet-bytes"},
      {"encode --packet-bytes 65508 " + src + " -o " + out, "--packet-bytes"},
      {"encode --packet-bytes -1 " + src + " -o " + out, "--packet-bytes"},
      {"encode --levels 256 " + src + " -o " + out, "--levels"},
      {"encode --base-ratio 0 " + src + " -o " + out, "--base-ratio"},
      {"encode --packing foo " + src + " -o " + out, "--packing"},
      {"decode --loss 1.01 " + out + " -o " + out, "--loss"},
      {"decode --loss nan " + out + " -o " + out, "--loss"},
      {"decode --reorder inf " + out + " -o " + out, "--reorder"},
      {"decode --seed 1.5 " + out + " -o " + out, "--seed"},
      {"decode --recovery guess " + out + " -o " + out, "--recovery"},
      {"convert --draco --cl 11 " + src + " " + out, "--cl"},
      {"convert --qp 12 " + src + " " + out, "--qp"},  // only with --draco
      {"compare --samples 10 " + src + " " + src, "--samples"},
      {"info --bogus " + src, "--bogus"},
      {"encode " + src, "--output"},
  };
  for (const Case& c : cases) {
    const auto r = RunCommand(Cli() + " " + c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_EQ(Lines(r.err), 1u) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.option), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("meshstream ", 0), 0u) << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.File("x.glb")));
  const auto verb = RunCommand(Cli() + " frobnicate");
  EXPECT_EQ(verb.exit_code, 2);
  EXPECT_EQ(Lines(verb.err), 1u) << verb.err;
  EXPECT_NE(verb.err.find("frobnicate"), std::string::npos) << verb.err;
}

// The ends of the ranges are accepted: --packet-bytes at kMinPacketBytes.
TEST(CliOptions, RangeEndsAreAccepted) {
  TempDir dir;
  const auto r = RunCommand(Cli() + " encode --json --levels 2 --packet-bytes 64 --base-ratio 1 " +
                            Quote(ModelPath("spot.obj")) + " -o " + Quote(dir.File("x.glb")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["packet_bytes"], 64);
}

// An option --foo-bar may come from MESHSTREAM_FOO_BAR; the command line wins;
// a bad value from the environment is a usage error that names both.
TEST(CliOptions, EncodeSettingsComeFromTheEnvironment) {
  TempDir dir;
  const std::string args = " encode --json --levels 2 " + Quote(ModelPath("spot.obj")) + " -o " + Quote(dir.File("x.glb"));
  const nlohmann::json plain = test_util::RunCliJson(args.substr(1));
  EXPECT_EQ(plain["packet_bytes"], 1200);
  EXPECT_EQ(plain["packing"], "split");

  const auto env = RunCommand("MESHSTREAM_PACKET_BYTES=300 MESHSTREAM_PACKING=bundled MESHSTREAM_QP=9 " + Cli() + args);
  ASSERT_EQ(env.exit_code, 0) << env.err;
  const nlohmann::json j = nlohmann::json::parse(env.out);
  EXPECT_EQ(j["packet_bytes"], 300);
  EXPECT_EQ(j["packing"], "bundled");
  EXPECT_EQ(j["qp"], 9);

  const auto wins = RunCommand("MESHSTREAM_PACKET_BYTES=300 " + Cli() + args + " --packet-bytes 500");
  ASSERT_EQ(wins.exit_code, 0) << wins.err;
  EXPECT_EQ(nlohmann::json::parse(wins.out)["packet_bytes"], 500);

  const auto bad = RunCommand("MESHSTREAM_PACKET_BYTES=10 " + Cli() + args);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(Lines(bad.err), 1u) << bad.err;
  EXPECT_NE(bad.err.find("--packet-bytes"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("MESHSTREAM_PACKET_BYTES"), std::string::npos) << bad.err;

  // The help names the variable.
  const auto help = RunCommand(Cli() + " encode --help");
  EXPECT_NE(help.out.find("MESHSTREAM_PACKET_BYTES"), std::string::npos) << help.out;
}

}  // namespace
}  // namespace meshstream
