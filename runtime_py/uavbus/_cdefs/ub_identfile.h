/* cffi cdef for runtime_c/include/ub/ub_identfile.h: identity, authority and revocations files (POSIX, in C). */

#define UB_IDENTFILE_ERR_LEN ...
#define UB_IDENTFILE_LEN ...
#define UB_AUTHFILE_LEN ...

int ub_identfile_write(const char *path, const ub_cert_t *cert, const uint8_t sign_seed[], const uint8_t kx_sk[],
                       bool force, char *err, size_t err_cap);
int ub_identfile_load(const char *path, ub_cert_t *cert, uint8_t sign_sk[], uint8_t kx_sk[], char *err, size_t err_cap);
int ub_authfile_write_secret(const char *path, const uint8_t seed[], char *err, size_t err_cap);
int ub_authfile_write_public(const char *path, const uint8_t pk[], bool force, char *err, size_t err_cap);
int ub_authfile_load_secret(const char *path, uint8_t sk[], char *err, size_t err_cap);
int ub_authfile_load_public(const char *path, uint8_t pk[], char *err, size_t err_cap);
int ub_revfile_load(const char *path, ub_ident_store_t *store, char *err, size_t err_cap);
int ub_revfile_save(const char *path, const ub_ident_store_t *store, char *err, size_t err_cap);
int ub_identfile_load_store(ub_ident_store_t *store, const char *identity_path, const char *authority_path,
                            const char *revocations_path, uint64_t now_s, char *err, size_t err_cap);
int ub_certfile_put(const char *path, const uint8_t *cert, size_t len, char *err, size_t err_cap);
int ub_certfile_load(const char *path, ub_ident_store_t *store, uint64_t now_s, char *err, size_t err_cap);
int ub_revfile_read(const char *path, uint8_t *records, size_t cap, char *err, size_t err_cap);
int ub_revfile_persist(void *user, const ub_ident_store_t *store);
int ub_ident_roles_now(void *store, const uint8_t id[], uint16_t *roles);
uint64_t ub_identfile_unix_s(void *user);
bool ub_identfile_route_certified(void *user, const uint8_t dest[], const uint8_t neighbour[], uint16_t metric);
int ub_certfile_persist(void *user, const uint8_t *cert, size_t len);
