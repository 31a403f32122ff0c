// The Status -> HTTP mapping and JSON errors (services/http/http_message.h).
#include "services/http/http_message.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace meshstream {
namespace {

TEST(HttpMessage, StatusMapping) {
  EXPECT_EQ(HttpStatusOf(StatusCode::kInvalidArgument), 400);
  EXPECT_EQ(HttpStatusOf(StatusCode::kInvalidInput), 400);
  EXPECT_EQ(HttpStatusOf(StatusCode::kUnauthenticated), 401);
  EXPECT_EQ(HttpStatusOf(StatusCode::kPermissionDenied), 403);
  EXPECT_EQ(HttpStatusOf(StatusCode::kNotFound), 404);
  EXPECT_EQ(HttpStatusOf(StatusCode::kFailedPrecondition), 409);
  EXPECT_EQ(HttpStatusOf(StatusCode::kResourceExhausted), 429);
  EXPECT_EQ(HttpStatusOf(StatusCode::kUnavailable), 503);
  EXPECT_EQ(HttpStatusOf(StatusCode::kDataLoss), 500);
  EXPECT_EQ(HttpStatusOf(StatusCode::kInternal), 500);
}

TEST(HttpMessage, ErrorsAreJson) {
  HttpResponse r = StatusResponse(Unauthenticated("no token"));
  EXPECT_EQ(r.status, 401);
  EXPECT_EQ(r.Header("WWW-Authenticate"), "Bearer realm=\"meshstream\"");
  EXPECT_EQ(r.Header("Content-Type"), "application/json");
  EXPECT_EQ(r.Header("Cache-Control"), "no-store");
  auto body = nlohmann::json::parse(r.body());
  EXPECT_EQ(body["error"], "no token");
  EXPECT_EQ(body["code"], "UNAUTHENTICATED");

  r = StatusResponse(Unavailable("busy"));
  EXPECT_EQ(r.status, 503);
  EXPECT_EQ(r.Header("Retry-After"), std::to_string(kRetryAfterSeconds));

  // Bytes that are not UTF-8 still make valid JSON.
  r = JsonError(400, "bad \xff\xfe name \"quoted\"\n");
  body = nlohmann::json::parse(r.body());
  EXPECT_NE(body["error"].get<std::string>().find("\"quoted\""), std::string::npos);
}

TEST(HttpMessage, Headers) {
  HttpRequest q;
  q.headers = {{"range", "bytes=0-1"}, {"if-none-match", "\"a\""}, {"if-none-match", "\"b\""}};
  EXPECT_EQ(q.Header("if-none-match"), "\"a\", \"b\"");
  EXPECT_FALSE(q.Header("authorization"));
  HttpResponse r;
  r.SetHeader("Vary", "Origin");
  r.AppendToken("vary", "origin");
  r.AppendToken("Vary", "Authorization");
  EXPECT_EQ(r.Header("VARY"), "Origin, Authorization");
  r.SetHeader("vary", "x");
  EXPECT_EQ(r.headers.size(), 1u);
}

TEST(HttpMessage, Date) { EXPECT_EQ(HttpDate(784111777), "Sun, 06 Nov 1994 08:49:37 GMT"); }

}  // namespace
}  // namespace meshstream
