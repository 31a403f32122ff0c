// A real `meshstream serve` process for integration tests: started with
// --listen 127.0.0.1:0 (a free port) and --ready-file, its addresses read
// from that file once the server writes it (every listener up), its stderr
// kept in a file, and stopped with SIGTERM (drain) or SIGKILL (a crash).
// testing/serve.sh is the same fixture for shell scripts.
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
    p->ready_path_ = p->dir_.File("ready.json");
    argv_text.push_back("--ready-file");
    argv_text.push_back(p->ready_path_);
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
    // The ready file: {"grpc": ADDRESS, "udp": ADDRESS|null, "http": ADDRESS|null}.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<int>(timeout_s * 1000));
    std::string ready;
    while (ready.empty()) {
      if (std::chrono::steady_clock::now() > deadline) {
        return Unavailable("serve did not write its ready file within the timeout: " + p->log());
      }
      int status = 0;
      if (waitpid(pid, &status, WNOHANG) == pid) {
        const int code = p->Record(status);
        return Unavailable("serve exited (" + std::to_string(code) + ") before listening: " + p->log());
      }
      ready = ReadText(p->ready_path_);
      if (ready.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    p->address_ = ReadyField(ready, "grpc");
    p->udp_address_ = ReadyField(ready, "udp");
    p->http_address_ = ReadyField(ready, "http");
    if (p->address_.empty()) return Internal("serve's ready file names no gRPC address: " + ready);
    return p;
  }

  ~ServeProcess() {
    if (running()) Kill();
    if (stdout_fd_ >= 0) close(stdout_fd_);
  }

  const std::string& address() const { return address_; }
  // The UDP endpoint of the sessions ("127.0.0.1:PORT"), empty when UDP is off.
  const std::string& udp_address() const { return udp_address_; }
  // The HTTP listener (--http-listen), empty when HTTP is off.
  const std::string& http_address() const { return http_address_; }
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

  // The string value of `key` in the ready file's one-line JSON object
  // (serve writes it: string values without escapes, or null); "" for null
  // or a missing key.
  static std::string ReadyField(const std::string& json, const std::string& key) {
    const std::string quoted = "\"" + key + "\":\"";
    const size_t at = json.find(quoted);
    if (at == std::string::npos) return "";
    const size_t begin = at + quoted.size();
    const size_t end = json.find('"', begin);
    return end == std::string::npos ? "" : json.substr(begin, end - begin);
  }

  TempDir dir_;
  std::string log_path_;
  std::string ready_path_;
  std::string address_;
  std::string udp_address_;
  std::string http_address_;
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
