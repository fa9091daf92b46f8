// SPDX-License-Identifier: MIT
#include "shard_auth.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <openssl/evp.h>
#include <openssl/hmac.h>

namespace lidarflow::bridge {

std::vector<uint8_t> shard_mac_message(const std::string &key, int32_t index, int32_t count, const std::string &channel,
                                       const void *payload, size_t size) {
    static const char kDomain[] = "lidarflow shard mac v1";  // with its NUL
    std::vector<uint8_t> in;
    in.reserve(sizeof kDomain + 8 + channel.size() + 1 + size);
    in.insert(in.end(), kDomain, kDomain + sizeof kDomain);
    uint8_t head[8];
    for (int i = 0; i < 4; ++i) {
        head[i] = static_cast<uint8_t>(static_cast<uint32_t>(index) >> (24 - 8 * i));
        head[4 + i] = static_cast<uint8_t>(static_cast<uint32_t>(count) >> (24 - 8 * i));
    }
    in.insert(in.end(), head, head + 8);
    in.insert(in.end(), channel.begin(), channel.end());
    in.push_back(0);
    const auto *p = static_cast<const uint8_t *>(payload);
    in.insert(in.end(), p, p + size);
    std::vector<uint8_t> out(48);
    std::memcpy(out.data(), "LFMAC\x01\0\0", 8);
    std::memcpy(out.data() + 8, head, 8);
    unsigned int len = 0;
    if (!HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), in.data(), in.size(), out.data() + 16, &len) ||
        len != 32)
        return {};
    return out;
}

std::vector<uint8_t> shard_receipt_message(int32_t index, int32_t count, int64_t instance, const std::string &channel,
                                           const void *payload, size_t size) {
    std::vector<uint8_t> out(48);
    std::memcpy(out.data(), "LFRCP\x01\0\0", 8);
    for (int i = 0; i < 4; ++i) {
        out[8 + i] = static_cast<uint8_t>(static_cast<uint32_t>(index) >> (24 - 8 * i));
        out[12 + i] = static_cast<uint8_t>(static_cast<uint32_t>(count) >> (24 - 8 * i));
    }
    for (int i = 0; i < 8; ++i) out[16 + i] = static_cast<uint8_t>(static_cast<uint64_t>(instance) >> (56 - 8 * i));
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
