// A real `meshstream serve` process for integration tests: started with
// --listen 127.0.0.1:0 (a free port), its address read from the first line
// of its stdout ("listening on HOST:PORT"), its stderr kept in a file, and
// stopped with SIGTERM (drain) or SIGKILL (a crash).
#ifndef MESHSTREAM_TESTING_SERVE_PROCESS_H_
#define MESHSTREAM_TESTING_SERVE_PROCESS_H_

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "codec/core/status.h"
#include "testing/test_util.h"

namespace meshstream::test_util {

class ServeProcess {
 public:
  // `args` follow `meshstream serve`; --listen 127.0.0.1:0 is added unless
  // `args` has a --listen. `env` entries are "NAME=VALUE".
  static StatusOr<std::unique_ptr<ServeProcess>> Start(const std::vector<std::string>& args,
                                                       const std::vector<std::string>& env = {},
                                                       double timeout_s = 60) {
    auto p = std::unique_ptr<ServeProcess>(new ServeProcess());
    p->log_path_ = p->dir_.File("serve.log");
    int out[2];
    if (pipe(out) != 0) return IoError("pipe failed");
    std::vector<std::string> argv_text = {MESHSTREAM_CLI, "serve"};
    bool has_listen = false;
    for (const std::string& a : args) has_listen = has_listen || a == "--listen" || a.rfind("--listen=", 0) == 0;
    if (!has_listen) {
      argv_text.push_back("--listen");
      argv_text.push_back("127.0.0.1:0");
    }
    argv_text.insert(argv_text.end(), args.begin(), args.end());
    const pid_t pid = fork();
    if (pid < 0) return IoError("fork failed");
    if (pid == 0) {
      dup2(out[1], STDOUT_FILENO);
      const int log = open(p->log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      if (log >= 0) dup2(log, STDERR_FILENO);
      const int null = open("/dev/null", O_RDONLY);
      if (null >= 0) dup2(null, STDIN_FILENO);
      close(out[0]);
      for (const std::string& e : env) putenv(const_cast<char*>(e.c_str()));
      std::vector<char*> argv;
      for (std::string& a : argv_text) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
    close(out[1]);
    p->pid_ = pid;
    p->stdout_fd_ = out[0];
    // The first line on stdout: "listening on ADDRESS".
    std::string line;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int>(timeout_s * 1000));
    while (line.find('\n') == std::string::npos) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return Unavailable("serve did not say where it listens within the timeout: " + p->log());
      pollfd fd{out[0], POLLIN, 0};
      if (poll(&fd, 1, static_cast<int>(left.count())) <= 0) continue;
      char buffer[256];
      const ssize_t n = read(out[0], buffer, sizeof buffer);
      if (n <= 0) {
        const int code = p->WaitExit();
        return Unavailable("serve exited (" + std::to_string(code) + ") before listening: " + p->log());
      }
      line.append(buffer, static_cast<size_t>(n));
    }
    const std::string prefix = "listening on ";
    if (line.rfind(prefix, 0) != 0) return Internal("unexpected first line of serve: " + line);
    p->address_ = line.substr(prefix.size(), line.find('\n') - prefix.size());
    // serve writes "udp on HOST:PORT" in the same flush, when UDP is on.
    const std::string udp_prefix = "udp on ";
    const size_t second = line.find('\n') + 1;
    if (line.compare(second, udp_prefix.size(), udp_prefix) == 0) {
      const size_t end = line.find('\n', second);
      p->udp_address_ = line.substr(second + udp_prefix.size(), end == std::string::npos ? std::string::npos : end - second - udp_prefix.size());
    }
    return p;
  }

  ~ServeProcess() {
    if (running()) Kill();
    if (stdout_fd_ >= 0) close(stdout_fd_);
  }

  const std::string& address() const { return address_; }
  // The UDP endpoint of the sessions ("127.0.0.1:PORT"), empty when UDP is off.
  const std::string& udp_address() const { return udp_address_; }
  pid_t pid() const { return pid_; }
  bool running() const { return pid_ > 0 && !exited_; }
  std::string log() const { return ReadText(log_path_); }

  // SIGTERM, then the exit code (or 128 + signal); SIGKILL after `timeout_s`.
  int Terminate(double timeout_s = 60) {
    if (!running()) return exit_code_;
    kill(pid_, SIGTERM);
    return WaitForExit(timeout_s);
  }

  // The exit code once the process ends by itself; SIGKILL after `timeout_s`
  // (returns -1 then).
  int WaitForExit(double timeout_s) {
    if (!running()) return exit_code_;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int>(timeout_s * 1000));
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) return Record(status);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    Kill();
    return -1;
  }

  // SIGKILL: the process dies at once, as in a crash or a power cut.
  void Kill() {
    if (!running()) return;
    kill(pid_, SIGKILL);
    WaitExit();
  }

 private:
  ServeProcess() = default;
  int WaitExit() {
    int status = 0;
    if (waitpid(pid_, &status, 0) == pid_) return Record(status);
    exited_ = true;
    return exit_code_;
  }
  int Record(int status) {
    exited_ = true;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return exit_code_;
  }

  TempDir dir_;
  std::string log_path_;
  std::string address_;
  std::string udp_address_;
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  bool exited_ = false;
  int exit_code_ = -1;
};

// The server most integration suites share, for SetUpTestSuite and
// TearDownTestSuite: `meshstream serve` on an embedded store in a fresh
// temporary folder, with two workers.
struct SuiteServer {
  TempDir* dir = nullptr;
  ServeProcess* server = nullptr;

  Status Start() {
    dir = new TempDir();
    auto started = ServeProcess::Start({"--store", dir->File("store"), "--workers", "2"});
    if (!started.ok()) return started.status();
    server = started.value().release();
    return Status::Ok();
  }
  // The server's exit code after SIGTERM (0: drained cleanly), with its log
  // in `*log`; both folders are gone afterwards.
  int Stop(std::string* log) {
    int code = 0;
    if (server != nullptr) {
      code = server->Terminate();
      *log = server->log();
    }
    delete server;
    delete dir;
    server = nullptr;
    dir = nullptr;
    return code;
  }
};

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_SERVE_PROCESS_H_
