// SPDX-License-Identifier: MIT
#include "shard_auth.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include "wire_detail.hpp"

namespace lidarflow::bridge {

using detail::read_be;
using detail::write_be;

namespace {

constexpr size_t kMacHead = 64;  // up to the echoes

// HMAC-SHA256 of a MAC message's bytes before the HMAC, bound to its channel.
bool mac_of(const std::string &key, const std::string &channel, const uint8_t *bytes, size_t size, uint8_t out[32]) {
    static const char kDomain[] = "lidarflow shard mac v2";  // with its NUL
    std::vector<uint8_t> in;
    in.reserve(sizeof kDomain + channel.size() + 1 + size);
    in.insert(in.end(), kDomain, kDomain + sizeof kDomain);
    in.insert(in.end(), channel.begin(), channel.end());
    in.push_back(0);
    in.insert(in.end(), bytes, bytes + size);
    unsigned int len = 0;
    return HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), in.data(), in.size(), out, &len) && len == 32;
}

}  // namespace

bool message_digest(const void *payload, size_t size, Digest *out) {
    unsigned int len = 0;
    return EVP_Digest(payload, size, out->data(), &len, EVP_sha256(), nullptr) == 1 && len == 32;
}

std::vector<uint8_t> shard_mac_message(const std::string &key, ShardMacKind kind, int32_t index, int32_t count,
                                       int64_t utime, int64_t instance, const std::vector<uint64_t> &echoes,
                                       const std::string &channel, const void *payload, size_t size) {
    if (count < 1 || (!echoes.empty() && echoes.size() != static_cast<size_t>(count))) return {};
    const size_t body = kMacHead + 8 * static_cast<size_t>(count);
    std::vector<uint8_t> out(body + 32);
    std::memcpy(out.data(), "LFMAC\x02", 6);
    out[6] = static_cast<uint8_t>(kind);
    write_be(&out[8], static_cast<uint32_t>(index), 4);
    write_be(&out[12], static_cast<uint32_t>(count), 4);
    write_be(&out[16], static_cast<uint64_t>(utime), 8);
    write_be(&out[24], static_cast<uint64_t>(instance), 8);
    Digest digest;
    if (!message_digest(payload, size, &digest)) return {};
    std::memcpy(&out[32], digest.data(), digest.size());
    for (size_t j = 0; j < echoes.size(); ++j) write_be(&out[kMacHead + 8 * j], echoes[j], 8);
    if (!mac_of(key, channel, out.data(), body, &out[body])) return {};
    return out;
}

std::string check_shard_mac(const std::string &key, int32_t count, const std::string &status_channel,
                            const std::string &flow_channel, const void *data, size_t size, ShardMac *out) {
    const auto *d = static_cast<const uint8_t *>(data);
    if (size == 48 && std::memcmp(d, "LFMAC\x01\0\0", 8) == 0)
        return "version 1 (an older lidarflow-lcm-bridge): it proves no freshness";
    if (count < 1 || size != kMacHead + 8 * static_cast<size_t>(count) + 32)
        return "not a MAC message of " + std::to_string(count) + " shards (" + std::to_string(size) + " bytes)";
    if (std::memcmp(d, "LFMAC\x02", 6) != 0 || d[7] != 0 || (d[6] != 1 && d[6] != 2))
        return "not a MAC message (bad header)";
    if (static_cast<int32_t>(read_be(d + 12, 4)) != count) return "a MAC of another split";
    const auto kind = static_cast<ShardMacKind>(d[6]);
    const size_t body = size - 32;
    uint8_t mac[32];
    if (!mac_of(key, kind == ShardMacKind::Status ? status_channel : flow_channel, d, body, mac))
        return "libcrypto failed";
    if (CRYPTO_memcmp(mac, d + body, 32) != 0) return "wrong MAC (another key, or altered)";
    out->kind = kind;
    out->index = static_cast<int32_t>(read_be(d + 8, 4));
    out->count = count;
    if (out->index < 0 || out->index >= count) return "shard index out of range";
    out->utime = read_be(d + 16, 8);
    out->instance = read_be(d + 24, 8);
    std::memcpy(out->digest.data(), d + 32, out->digest.size());
    out->echoes.resize(static_cast<size_t>(count));
    for (size_t j = 0; j < out->echoes.size(); ++j)
        out->echoes[j] = static_cast<uint64_t>(read_be(d + kMacHead + 8 * j, 8));
    out->tag = static_cast<uint64_t>(read_be(d + body, 8));
    return "";
}

std::vector<uint8_t> shard_receipt_message(int32_t index, int32_t count, int64_t instance, const std::string &channel,
                                           const void *payload, size_t size) {
    std::vector<uint8_t> out(48);
    std::memcpy(out.data(), "LFRCP\x01\0\0", 8);
    write_be(&out[8], static_cast<uint32_t>(index), 4);
    write_be(&out[12], static_cast<uint32_t>(count), 4);
    write_be(&out[16], static_cast<uint64_t>(instance), 8);
    unsigned char digest[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    const bool ok = ctx && EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr) == 1 &&
                    EVP_DigestUpdate(ctx, channel.c_str(), channel.size() + 1) == 1 &&
                    EVP_DigestUpdate(ctx, payload, size) == 1 && EVP_DigestFinal_ex(ctx, digest, &len) == 1 && len == 32;
    EVP_MD_CTX_free(ctx);
    if (!ok) return {};
    std::memcpy(out.data() + 24, digest, 24);
    return out;
}

std::string read_shard_key(const std::string &path, std::string *key) {
    std::FILE *f = std::fopen(path.c_str(), "rb");
    if (!f) return path + ": " + std::strerror(errno);
    std::string k;
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0 && k.size() < (1u << 20)) k.append(buf, n);
    const bool bad = std::ferror(f);
    std::fclose(f);
    if (bad) return path + ": read error";
    while (!k.empty() && (k.back() == '\n' || k.back() == '\r')) k.pop_back();  // `openssl rand -hex 32 >FILE`
    if (k.size() < 16) return path + ": a shard key needs at least 16 bytes";
    *key = std::move(k);
    return "";
}
}  // namespace lidarflow::bridge
