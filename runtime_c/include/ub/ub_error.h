/**
 * @file ub_error.h
 * @brief uavbus error codes: every fallible runtime function returns an `int`
 *        that is 0 (or a non-negative count) on success and one of these
 *        negative codes on failure.
 *
 * Functions that can fail are declared UB_CHECK (warn_unused_result), so a
 * dropped error is a compiler warning, and with -Werror a build failure.
 */
#ifndef UB_ERROR_H
#define UB_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__) || defined(__clang__)
#define UB_CHECK __attribute__((warn_unused_result))
#else
#define UB_CHECK
#endif

#define UB_OK 0
#define UB_ERR_INVAL -1      /**< an argument is out of range or NULL */
#define UB_ERR_NOSPACE -2    /**< output buffer too small */
#define UB_ERR_TRUNCATED -3  /**< input shorter than the encoding needs */
#define UB_ERR_FULL -4       /**< a fixed-capacity table is full (see ub_config.h) */
#define UB_ERR_NOTFOUND -5   /**< no such entity, instance, link or row */
#define UB_ERR_EXISTS -6     /**< the item is already present */
#define UB_ERR_CHECKSUM -7   /**< header check or message CRC mismatch */
#define UB_ERR_LAYOUT -8     /**< layout fingerprint mismatch: sender built from another definition */
#define UB_ERR_NOROUTE -9    /**< no link leads to the destination entity */
#define UB_ERR_IO -10        /**< operating-system I/O error (errno holds the detail) */
#define UB_ERR_AGAIN -11     /**< would block; try again when the descriptor is ready */
#define UB_ERR_CONFIG -12    /**< configuration is invalid (see the error text) */
#define UB_ERR_CLOSED -13    /**< the link or peer is closed */
#define UB_ERR_RANGE -14     /**< a value does not fit its wire field */
#define UB_ERR_AUTH -15      /**< authentication failed: a frame's tag does not verify (ub_sec.h) */
#define UB_ERR_UNSUPPORTED -16 /**< not in this build (e.g. security with UAVBUS_SECURITY=OFF) */
#define UB_ERR_REFUSED -22   /**< the remote target answered with a NACK (its reason says why; ub_inspect.h) */
#define UB_ERR_NOANSWER -23  /**< the remote target did not answer within the retries (ub_inspect.h) */

/** @return a static, human-readable name for an error code ("UB_ERR_INVAL"...). */
const char *ub_strerror(int err);

#ifdef __cplusplus
}
#endif
#endif /* UB_ERROR_H */
