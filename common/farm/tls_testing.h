// A self-signed certificate for the tests of the daemons' TLS (the HTTP server's).
#pragma once

#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>

#include <cstdio>
#include <filesystem>
#include <string>

namespace alphorn::farm {

// A self-signed P-256 certificate for 127.0.0.1, written as PEM files.
struct TestCertificate {
    std::string certPath, keyPath;
};

inline TestCertificate makeCertificate(const std::filesystem::path& directory) {
    std::filesystem::create_directories(directory);
    TestCertificate files{(directory / "cert.pem").string(), (directory / "key.pem").string()};
    EVP_PKEY* key = EVP_EC_gen("P-256");
    X509* cert = X509_new();
    X509_set_version(cert, 2);
    ASN1_INTEGER_set(X509_get_serialNumber(cert), 1);
    X509_gmtime_adj(X509_getm_notBefore(cert), -60);
    X509_gmtime_adj(X509_getm_notAfter(cert), 3600);
    X509_set_pubkey(cert, key);
    X509_NAME* name = X509_get_subject_name(cert);
    X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_ASC,
                               reinterpret_cast<const unsigned char*>("localhost"), -1, -1, 0);
    X509_set_issuer_name(cert, name);
    X509V3_CTX context;
    X509V3_set_ctx_nodb(&context);
    X509V3_set_ctx(&context, cert, cert, nullptr, nullptr, 0);
    X509_EXTENSION* san =
        X509V3_EXT_conf_nid(nullptr, &context, NID_subject_alt_name, "IP:127.0.0.1,DNS:localhost");
    X509_add_ext(cert, san, -1);
    X509_EXTENSION_free(san);
    X509_sign(cert, key, EVP_sha256());
    FILE* certFile = std::fopen(files.certPath.c_str(), "w");
    PEM_write_X509(certFile, cert);
    std::fclose(certFile);
    FILE* keyFile = std::fopen(files.keyPath.c_str(), "w");
    PEM_write_PrivateKey(keyFile, key, nullptr, nullptr, 0, nullptr, nullptr);
    std::fclose(keyFile);
    X509_free(cert);
    EVP_PKEY_free(key);
    return files;
}

}  // namespace alphorn::farm
