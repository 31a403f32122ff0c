// The verbs of the meshstream command. Each Add* declares its subcommand and
// options on `root` (cli/app.h) and returns what runs when it is chosen: a thin
// layer from the parsed arguments to the libraries, returning the exit code
// (exit_codes.h).
#ifndef MESHSTREAM_CLI_VERBS_H_
#define MESHSTREAM_CLI_VERBS_H_

#include "cli/app.h"

namespace meshstream::cli {

Verb AddInfo(CLI::App& root);
Verb AddConvert(CLI::App& root);
Verb AddCompare(CLI::App& root);
Verb AddEncode(CLI::App& root);
Verb AddDecode(CLI::App& root);
Verb AddServe(CLI::App& root);
Verb AddIngest(CLI::App& root);
Verb AddVersions(CLI::App& root);
Verb AddAssets(CLI::App& root);
Verb AddExport(CLI::App& root);
Verb AddToken(CLI::App& root);
Verb AddFetch(CLI::App& root);

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_VERBS_H_
