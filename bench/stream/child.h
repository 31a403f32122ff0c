// This program again as a child process (a client of the stream benchmark's
// server, so that the server's process CPU is the server's alone): its
// stdin and stdout are pipes to the parent, read and written line by line.
//
// Thread safety: one thread uses a ChildProcess.
#ifndef MESHSTREAM_BENCH_STREAM_CHILD_H_
#define MESHSTREAM_BENCH_STREAM_CHILD_H_

#include <sys/types.h>

#include <cstdio>
#include <string>
#include <vector>

namespace meshstream::bench::stream {

class ChildProcess {
 public:
  // /proc/self/exe with `args` (argv[1..]), at niceness `nice` (0: this
  // process's; through nice(1) otherwise, so that every thread of the child
  // has it); Die when it cannot start.
  explicit ChildProcess(const std::vector<std::string>& args, int nice = 0);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // One line to its stdin (a newline is added).
  void WriteLine(const std::string& line);
  // Its next line on stdout, without the newline; Die when it ended first.
  std::string NextLine();
  // Closes both pipes and waits for it; Die unless it exited with 0.
  void Wait();

 private:
  pid_t pid_ = 0;
  FILE* in_ = nullptr;   // its stdin
  FILE* out_ = nullptr;  // its stdout
  std::string what_;     // argv[1], for the messages
};

}  // namespace meshstream::bench::stream

#endif  // MESHSTREAM_BENCH_STREAM_CHILD_H_
