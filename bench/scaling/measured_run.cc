#include "bench/scaling/measured_run.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>

extern char** environ;

namespace meshstream::bench {

namespace {

MeasuredRun SpawnAndMeasure(const std::vector<std::string>& argv) {
  MeasuredRun r;
  int out_pipe[2];
  if (argv.empty() || pipe(out_pipe) != 0) return r;
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out_pipe[1], STDOUT_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addclose(&actions, out_pipe[0]);
  posix_spawn_file_actions_addclose(&actions, out_pipe[1]);
  const auto begin = std::chrono::steady_clock::now();
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(out_pipe[1]);
  if (spawned != 0) {
    close(out_pipe[0]);
    return r;
  }
  char buffer[4096];
  for (ssize_t n; (n = read(out_pipe[0], buffer, sizeof buffer)) != 0;) {
    if (n < 0) break;
    r.out.append(buffer, static_cast<size_t>(n));
  }
  close(out_pipe[0]);
  int status = 0;
  struct rusage usage {};
  if (wait4(pid, &status, 0, &usage) != pid) return r;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  r.cpu_s = usage.ru_utime.tv_sec + usage.ru_utime.tv_usec / 1e6 + usage.ru_stime.tv_sec + usage.ru_stime.tv_usec / 1e6;
  r.peak_rss_bytes = static_cast<uint64_t>(usage.ru_maxrss) * 1024;  // Linux: kilobytes
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// The spawner's protocol over two pipes: a request is a count of
// arguments then each as a length and its bytes; the answer is the exit
// code, wall, CPU, peak and the stdout as a length and its bytes.
int to_spawner = -1, from_spawner = -1;

// Every byte of [p, p + n) through `io` (read or write), however many calls it takes.
template <class Byte, class Io>
bool Transfer(int fd, Byte* p, size_t n, Io io) {
  while (n > 0) {
    const ssize_t done = io(fd, p, n);
    if (done <= 0) return false;
    p += done;
    n -= static_cast<size_t>(done);
  }
  return true;
}

bool WriteAll(int fd, const void* data, size_t n) { return Transfer(fd, static_cast<const char*>(data), n, write); }
bool ReadAll(int fd, void* data, size_t n) { return Transfer(fd, static_cast<char*>(data), n, read); }

bool WriteString(int fd, const std::string& s) {
  const uint64_t n = s.size();
  return WriteAll(fd, &n, sizeof n) && WriteAll(fd, s.data(), s.size());
}

bool ReadString(int fd, std::string* s) {
  uint64_t n = 0;
  if (!ReadAll(fd, &n, sizeof n) || n > (uint64_t{1} << 32)) return false;
  s->resize(n);
  return ReadAll(fd, s->data(), n);
}

[[noreturn]] void ServeRequests(int in, int out) {
  for (;;) {
    uint64_t count = 0;
    if (!ReadAll(in, &count, sizeof count) || count > 4096) _exit(0);
    std::vector<std::string> argv(count);
    for (std::string& a : argv)
      if (!ReadString(in, &a)) _exit(0);
    const MeasuredRun r = SpawnAndMeasure(argv);
    const int64_t code = r.exit_code;
    const uint64_t peak = r.peak_rss_bytes;
    if (!WriteAll(out, &code, sizeof code) || !WriteAll(out, &r.wall_s, sizeof r.wall_s) ||
        !WriteAll(out, &r.cpu_s, sizeof r.cpu_s) || !WriteAll(out, &peak, sizeof peak) || !WriteString(out, r.out)) {
      _exit(0);
    }
  }
}

}  // namespace

void StartSpawner() {
  int requests[2], answers[2];
  if (pipe(requests) != 0 || pipe(answers) != 0) return;
  const pid_t pid = fork();
  if (pid < 0) return;
  if (pid == 0) {
    close(requests[1]);
    close(answers[0]);
    ServeRequests(requests[0], answers[1]);
  }
  close(requests[0]);
  close(answers[1]);
  to_spawner = requests[1];
  from_spawner = answers[0];
}

MeasuredRun RunMeasured(const std::vector<std::string>& argv) {
  if (to_spawner < 0) return SpawnAndMeasure(argv);
  MeasuredRun r;
  const uint64_t count = argv.size();
  bool ok = WriteAll(to_spawner, &count, sizeof count);
  for (const std::string& a : argv) ok = ok && WriteString(to_spawner, a);
  int64_t code = -1;
  uint64_t peak = 0;
  ok = ok && ReadAll(from_spawner, &code, sizeof code) && ReadAll(from_spawner, &r.wall_s, sizeof r.wall_s) &&
       ReadAll(from_spawner, &r.cpu_s, sizeof r.cpu_s) && ReadAll(from_spawner, &peak, sizeof peak) &&
       ReadString(from_spawner, &r.out);
  if (!ok) return MeasuredRun{};
  r.exit_code = static_cast<int>(code);
  r.peak_rss_bytes = peak;
  return r;
}

}  // namespace meshstream::bench
