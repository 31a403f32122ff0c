#include "cli/app.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <vector>

#include "cli/exit_codes.h"
#include "cli/verbs.h"

namespace meshstream::cli {

namespace {

// Help as "usage: ..." first, then the summary, the arguments, and the details.
class HelpFormatter : public CLI::Formatter {
 public:
  HelpFormatter() {
    label("Usage", "usage");
    column_width(30);
  }
  std::string make_help(const CLI::App* app, std::string name, CLI::AppFormatMode mode) const override {
    if (mode == CLI::AppFormatMode::Sub) return make_expanded(app);
    std::stringstream out;
    out << make_usage(app, name) << '\n' << make_description(app) << make_positionals(app) << make_groups(app, mode)
        << make_subcommands(app, mode) << '\n'
        << make_footer(app);
    return out.str();
  }
};

const char kRootFooter[] =
    "Inputs: .gltf .glb .obj .ply .off .stl. Outputs: .gltf .glb (decode also .obj .ply).\n"
    "Run 'meshstream VERB --help' for the options of a verb.\n"
    "Exit status: 0 success, 1 bad input (or refused by the server), 2 bad usage, 3 server unreachable.\n"
    "Options marked Env may also be set from that environment variable (docs/spec/cli.md).\n"
    "\n"
    "Example:\n"
    "  meshstream encode bunny.obj -o bunny.glb && meshstream decode bunny.glb -o lod3.glb --lod 3";

// The verb a parse error belongs to: the last subcommand the parser entered.
std::string VerbOf(const CLI::App& root) {
  const std::vector<CLI::App*> chosen = root.get_subcommands();
  return chosen.empty() ? std::string() : chosen.back()->get_name();
}

// " (from MESHSTREAM_X)" when the option a parse error names took its value
// from the environment rather than the command line.
std::string EnvSource(const CLI::App& verb, const std::string& message, int argc, char** argv) {
  for (const CLI::Option* opt : verb.get_options()) {
    const std::string env = opt->get_envname();
    if (env.empty() || opt->get_lnames().empty() || std::getenv(env.c_str()) == nullptr) continue;
    const std::string flag = "--" + opt->get_lnames().front();
    if (message.find(flag) == std::string::npos) continue;
    bool on_command_line = false;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == flag || a.rfind(flag + "=", 0) == 0) on_command_line = true;
    }
    if (!on_command_line) return " (from " + env + ")";
  }
  return std::string();
}

}  // namespace

CLI::App* AddVerb(CLI::App& root, const std::string& name, const std::string& summary, const std::string& details) {
  CLI::App* verb = root.add_subcommand(name, summary);
  verb->footer(details);
  return verb;
}

std::string EnvName(const std::string& long_option_name) {
  std::string env = "MESHSTREAM_";
  size_t start = 0;
  while (start < long_option_name.size() && long_option_name[start] == '-') ++start;  // "--foo" or "foo"
  for (size_t i = start; i < long_option_name.size(); ++i) {
    const char c = long_option_name[i];
    env += c == '-' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  }
  return env;
}

CLI::Option* FromEnv(CLI::Option* option) {
  const std::vector<std::string> names = option->get_lnames();
  if (!names.empty()) option->envname(EnvName(names.front()));
  return option;
}

CLI::Validator NumberIn(double lo, double hi) {
  std::ostringstream range;
  range << "[" << lo << ", " << hi << "]";
  const std::string description = range.str();
  return CLI::Validator(
      [lo, hi, description](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
          return "must be a number in " + description + ", got '" + text + "'";
        }
        return std::string();
      },
      "NUMBER in " + description);
}

int Main(int argc, char** argv) {
  CLI::App root("Progressive 3D mesh streaming: import, convert, encode, decode and compare meshes.", "meshstream");
  root.formatter(std::make_shared<HelpFormatter>());
  root.set_version_flag("--version", std::string("meshstream ") + MESHSTREAM_VERSION, "print the version and exit");
  root.require_subcommand(1);
  root.footer(kRootFooter);
  const std::vector<Verb> verbs = {AddInfo(root),  AddConvert(root),  AddCompare(root), AddEncode(root),
                                   AddDecode(root), AddServe(root),    AddIngest(root),  AddVersions(root),
                                   AddAssets(root), AddExport(root),   AddToken(root),   AddFetch(root)};

  try {
    root.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << root.help() << std::flush;
    return kExitOk;
  } catch (const CLI::CallForAllHelp&) {
    std::cout << root.help("", CLI::AppFormatMode::All) << std::flush;
    return kExitOk;
  } catch (const CLI::CallForVersion& e) {
    std::cout << e.what() << std::endl;
    return kExitOk;
  } catch (const CLI::ParseError& e) {
    std::string verb = VerbOf(root);
    std::string message = e.what();
    if (!verb.empty()) message += EnvSource(*root.get_subcommand(verb), message, argc, argv);
    if (verb.empty() && argc >= 2 && argv[1][0] != '-') {
      message = std::string("unknown verb '") + argv[1] + "'";
    } else if (verb.empty() && argc < 2) {
      message = "a verb is required: info, convert, compare, encode, decode, serve, ingest, versions, assets, export, token or fetch";
    }
    return ReportError(verb, InvalidArgument(message));
  }
  for (const Verb& v : verbs) {
    if (v.command->parsed()) return v.run();
  }
  return ReportError("", InvalidArgument("a verb is required"));
}

}  // namespace meshstream::cli
