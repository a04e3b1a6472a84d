#include "calib_active.h"

calib_status_t calib_active_init(calib_active_t *active, calib_t *calib,
                                 const calib_named_t *compiled)
{
    active->calib = calib;
    uint32_t seq = 0;
    unsigned slot = CALIB_STORE_NO_SLOT;
    calib_named_t stored;
    if (calib_store_load(&stored, &slot, &seq) && calib_init(calib, &stored.params) == CALIB_OK) {
        active->current = stored;
        active->source = CALIB_SOURCE_FLASH;
        active->slot = slot;
        active->hash = calib_record_hash(&stored);
        return CALIB_OK;
    }
    active->current = *compiled;
    active->source = CALIB_SOURCE_COMPILED;
    active->slot = CALIB_STORE_NO_SLOT;
    active->hash = calib_record_hash(compiled);
    return calib_init(calib, &compiled->params);
}

calib_commit_t calib_active_commit(calib_active_t *active, const calib_named_t *candidate)
{
    calib_commit_t result = {calib_record_check(candidate), CALIB_STORE_OK};
    if (result.check != CALREC_OK) {
        return result;
    }
    calib_t trial;
    if (calib_init(&trial, &candidate->params) != CALIB_OK) {
        result.check = CALREC_SINGULAR; /* calib_record_check covers the rest */
        return result;
    }
    unsigned slot = CALIB_STORE_NO_SLOT;
    result.store = calib_store_save(candidate, &slot);
    if (result.store != CALIB_STORE_OK) {
        return result; /* the active calibration and its slot are untouched */
    }
    *active->calib = trial;
    active->current = *candidate;
    active->source = CALIB_SOURCE_FLASH;
    active->slot = slot;
    active->hash = calib_record_hash(candidate);
    return result;
}

const char *calib_source_name(calib_source_t source)
{
    return source == CALIB_SOURCE_FLASH ? "flash" : "compiled";
}
