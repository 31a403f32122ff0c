#include "bench/stream/child.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>

#include "bench/bench_util.h"

namespace meshstream::bench::stream {

ChildProcess::ChildProcess(const std::vector<std::string>& args, int nice) : what_(args.empty() ? "" : args.front()) {
  int in_pipe[2], out_pipe[2];
  if (pipe(in_pipe) != 0 || pipe(out_pipe) != 0) Die("pipe failed");
  const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
  std::vector<std::string> all = {self};
  if (nice != 0) all = {"/usr/bin/nice", "-n", std::to_string(nice), self};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, in_pipe[0], STDIN_FILENO);
  posix_spawn_file_actions_adddup2(&actions, out_pipe[1], STDOUT_FILENO);
  for (int fd : {in_pipe[0], in_pipe[1], out_pipe[0], out_pipe[1]}) posix_spawn_file_actions_addclose(&actions, fd);
  if (posix_spawn(&pid_, all.front().c_str(), &actions, nullptr, argv.data(), environ) != 0) {
    Die(all.front() + ": cannot start");
  }
  posix_spawn_file_actions_destroy(&actions);
  close(in_pipe[0]);
  close(out_pipe[1]);
  in_ = fdopen(in_pipe[1], "w");
  out_ = fdopen(out_pipe[0], "r");
  if (in_ == nullptr || out_ == nullptr) Die("fdopen failed");
}

ChildProcess::~ChildProcess() {
  if (pid_ == 0) return;
  if (in_ != nullptr) std::fclose(in_);
  if (out_ != nullptr) std::fclose(out_);
  int status = 0;
  waitpid(pid_, &status, 0);
}

void ChildProcess::WriteLine(const std::string& line) {
  if (std::fprintf(in_, "%s\n", line.c_str()) < 0 || std::fflush(in_) != 0) Die("the " + what_ + " child is gone");
}

std::string ChildProcess::NextLine() {
  std::string line;
  int c;
  while ((c = std::fgetc(out_)) != EOF && c != '\n') line.push_back(static_cast<char>(c));
  if (c == EOF && line.empty()) Die("the " + what_ + " child ended early");
  return line;
}

void ChildProcess::Wait() {
  std::fclose(in_);
  std::fclose(out_);
  in_ = out_ = nullptr;
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = 0;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) Die("the " + what_ + " child failed");
}

}  // namespace meshstream::bench::stream
