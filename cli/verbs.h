// The verbs of the meshstream command. Each takes the arguments after the verb
// and returns the process exit code (see exit_codes.h).
#ifndef MESHSTREAM_CLI_VERBS_H_
#define MESHSTREAM_CLI_VERBS_H_

#include <string>
#include <vector>

namespace meshstream::cli {

int RunInfo(const std::vector<std::string>& args);
int RunConvert(const std::vector<std::string>& args);
int RunCompare(const std::vector<std::string>& args);
int RunEncode(const std::vector<std::string>& args);
int RunDecode(const std::vector<std::string>& args);

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_VERBS_H_
