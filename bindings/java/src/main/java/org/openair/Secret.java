package org.openair;

import java.util.Objects;

/**
 * A module's secret for secure mode (spec 14.3, extension {@code auth}). It never travels: only
 * the HMAC proof does (OA-AUTH-12), and {@link #toString()} never shows it, so options can be
 * logged.
 *
 * @param value the secret as the server's secrets file holds it (its UTF-8 bytes are the key)
 */
public record Secret(String value) {
    /** Check the value. */
    public Secret {
        Objects.requireNonNull(value, "value");
        if (value.isEmpty()) {
            throw new ApiMisuseException("a secret must not be empty");
        }
    }

    @Override
    public String toString() {
        return "Secret[***]";
    }
}
