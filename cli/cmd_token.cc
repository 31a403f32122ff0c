// meshstream token create|list|revoke --store S
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <memory>

#include "cli/exit_codes.h"
#include "cli/json_out.h"
#include "cli/verbs.h"
#include "services/auth/api_token.h"
#include "services/store/open_store.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "API tokens of a server's store. A token belongs to one tenant, which sees only its own\n"
    "assets; a --read-only token cannot ingest. 'create' prints the token once, alone on the\n"
    "last line of stdout: the store keeps only its SHA-256. Works while the server runs (the\n"
    "server sees new and revoked tokens at the next request).\n"
    "\n"
    "Examples:\n"
    "  meshstream token create --store ./meshstream-data --tenant studio\n"
    "  meshstream token list --store ./meshstream-data\n"
    "  meshstream token revoke --store ./meshstream-data 3f2a9c1e0b7d4a65";

struct TokenArgs {
  std::string store = "./meshstream-data";
  std::string tenant;
  bool read_only = false;
  std::string id;
  bool json = false;
};

std::string Date(int64_t ms) {
  const std::time_t t = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%SZ", &tm);
  return text;
}

// `create` may make a new embedded store (tokens before the first start of
// the server), and says so; `list` and `revoke` never do (a mistyped --store
// would otherwise look like a store without tokens).
StatusOr<std::unique_ptr<Store>> Open(const TokenArgs& args, bool may_create) {
  if (!IsPostgresSpec(args.store)) {
    std::error_code ec;
    const bool exists = std::filesystem::exists(args.store + "/meta.sqlite3", ec);
    if (!exists && !may_create) return NotFound("--store " + args.store + ": no meshstream store there");
    if (!exists) std::fprintf(stderr, "meshstream token: note: no store at %s yet; creating it\n", args.store.c_str());
  }
  auto store = OpenStore(args.store, StoreLock::kShared);
  if (!store.ok()) return store.status().WithContext("--store " + args.store);
  return store;
}

int RunCreate(const TokenArgs& args) {
  Status s = CheckName("--tenant", args.tenant);
  if (!s.ok()) return ReportError("token create", s);
  auto store = Open(args, true);
  if (!store.ok()) return ReportError("token create", store.status());
  const std::string token = NewApiToken();
  if (!LooksLikeApiToken(token)) return ReportError("token create", Internal("no random bytes for a token"));
  auto record = (*store)->CreateToken(args.tenant, args.read_only, HashApiToken(token));
  if (!record.ok()) return ReportError("token create", record.status());
  if (args.json) {
    PrintJson({{"id", record->id}, {"tenant", record->tenant}, {"read_only", record->read_only}, {"token", token}});
  } else {
    std::printf("token %s for tenant %s (%s); it is shown once, keep it:\n%s\n", record->id.c_str(),
                record->tenant.c_str(), record->read_only ? "read-only" : "read-write", token.c_str());
  }
  return kExitOk;
}

int RunList(const TokenArgs& args) {
  auto store = Open(args, false);
  if (!store.ok()) return ReportError("token list", store.status());
  auto tokens = (*store)->ListTokens();
  if (!tokens.ok()) return ReportError("token list", tokens.status());
  if (args.json) {
    nlohmann::json list = nlohmann::json::array();
    for (const TokenRecord& t : tokens.value()) {
      list.push_back({{"id", t.id}, {"tenant", t.tenant}, {"read_only", t.read_only}, {"created_ms", t.created_ms},
                      {"revoked", t.revoked}});
    }
    PrintJson({{"tokens", list}});
    return kExitOk;
  }
  std::printf("%-16s  %-24s  %-10s  %-20s  %s\n", "ID", "TENANT", "ACCESS", "CREATED", "STATE");
  for (const TokenRecord& t : tokens.value()) {
    std::printf("%-16s  %-24s  %-10s  %-20s  %s\n", t.id.c_str(), t.tenant.c_str(),
                t.read_only ? "read-only" : "read-write", Date(t.created_ms).c_str(), t.revoked ? "revoked" : "live");
  }
  return kExitOk;
}

int RunRevoke(const TokenArgs& args) {
  auto store = Open(args, false);
  if (!store.ok()) return ReportError("token revoke", store.status());
  Status s = (*store)->RevokeToken(args.id);
  if (!s.ok()) return ReportError("token revoke", s);
  if (args.json) {
    PrintJson({{"id", args.id}, {"revoked", true}});
  } else {
    std::printf("token %s revoked\n", args.id.c_str());
  }
  return kExitOk;
}

}  // namespace

Verb AddToken(CLI::App& root) {
  auto args = std::make_shared<TokenArgs>();
  CLI::App* cmd = AddVerb(root, "token", "Creates, lists and revokes the API tokens of a store.", kDetails);
  cmd->require_subcommand(1);
  auto store_option = [&](CLI::App* sub) {
    FromEnv(sub->add_option("--store", args->store, "the server's store: a folder or postgresql://..."))
        ->capture_default_str();
    sub->add_flag("--json", args->json, "print one JSON object");
  };
  CLI::App* create = cmd->add_subcommand("create", "creates a token and prints it once");
  store_option(create);
  create->add_option("--tenant", args->tenant, "the tenant the token acts for, [A-Za-z0-9._-]{1,128}")->required();
  create->add_flag("--read-only", args->read_only, "may read and export, not ingest");
  CLI::App* list = cmd->add_subcommand("list", "lists the tokens (never their secret)");
  store_option(list);
  CLI::App* revoke = cmd->add_subcommand("revoke", "revokes a token by its id (from token list)");
  store_option(revoke);
  revoke->add_option("ID", args->id, "the token's id")->required();
  return {cmd, [args, create, list] {
            if (create->parsed()) return RunCreate(*args);
            if (list->parsed()) return RunList(*args);
            return RunRevoke(*args);
          }};
}

}  // namespace meshstream::cli
