package org.openair.internal;

import java.nio.charset.StandardCharsets;
import org.openair.ErrorCode;
import org.openair.RemoteProtocolException;

/**
 * Validation of message types and trigger/retrieve patterns (spec 5.1, 5.2).
 *
 * <p>A type is one or more non-empty segments separated by {@code .}; a segment holds printable,
 * non-whitespace characters other than {@code *} and {@code .} (OA-TYPE-1), {@code :} included
 * (OA-TYPE-2). A pattern follows the same rules except that {@code *} may appear inside segments,
 * never twice in a row (OA-MATCH-7). Both are limited to 255 UTF-8 bytes and 32 segments
 * (OA-TYPE-4, OA-MATCH-9). The characters refused are those of the table of spec 5.1
 * (OA-TYPE-5): the Unicode general categories Cc, Cf, Cs, Co, Zs, Zl and Zp as Unicode 14.0.0
 * assigns them, embedded as {@link #EXCLUDED} (the shared vector file
 * spec/vectors/unicode/segment-exclusions.json, which the tests compare), so validity does not
 * depend on the JDK's Unicode version; unassigned code points are allowed.
 *
 * <p>Threading: stateless; thread-safe.
 */
public final class Types {
    /** OA-TYPE-4. */
    public static final int MAX_BYTES = 255;
    /** OA-TYPE-4. */
    public static final int MAX_SEGMENTS = 32;

    private Types() {}

    /**
     * Return why {@code text} is not a valid type (or pattern), or null when it is valid.
     *
     * @param text the type or pattern
     * @param pattern whether {@code *} is allowed
     * @return the problem, or null
     */
    public static String problem(String text, boolean pattern) {
        if (text.isEmpty()) {
            return "is empty"; // OA-TYPE-1, OA-MSG-2
        }
        if (text.length() > MAX_BYTES) {
            return "is longer than " + MAX_BYTES + " bytes"; // OA-TYPE-4
        }
        int segments = 1;
        boolean segmentEmpty = true;
        char previous = 0;
        for (int i = 0; i < text.length(); ) {
            int cp = text.codePointAt(i);
            if (!printable(cp)) {
                return "contains white space or a non-printable character"; // OA-TYPE-1
            }
            if (cp == '*' && !pattern) {
                return "contains '*'"; // OA-TYPE-1, OA-TYPE-3
            }
            if (cp == '*' && previous == '*') {
                return "contains two consecutive '*'"; // OA-MATCH-7
            }
            if (cp == '.') {
                if (segmentEmpty) {
                    return "has an empty segment"; // OA-TYPE-1, OA-MATCH-7
                }
                segments++;
                segmentEmpty = true;
            } else {
                segmentEmpty = false;
            }
            previous = cp < 0x10000 ? (char) cp : 0;
            i += Character.charCount(cp);
        }
        if (segmentEmpty) {
            return "has an empty segment";
        }
        if (segments > MAX_SEGMENTS) {
            return "has more than " + MAX_SEGMENTS + " segments"; // OA-TYPE-4
        }
        if (text.getBytes(StandardCharsets.UTF_8).length > MAX_BYTES) {
            return "is longer than " + MAX_BYTES + " bytes"; // OA-TYPE-4
        }
        return null;
    }

    /**
     * The code points of the table of spec 5.1 (OA-TYPE-5), as inclusive pairs in ascending
     * order: Unicode 14.0.0 categories Cc, Cf, Cs, Co, Zs, Zl, Zp.
     */
    static final int[] EXCLUDED = {
        0x0, 0x1F, 0x20, 0x20, 0x7F, 0x9F, 0xA0, 0xA0, 0xAD, 0xAD, 0x600, 0x605, 0x61C, 0x61C,
        0x6DD, 0x6DD, 0x70F, 0x70F, 0x890, 0x891, 0x8E2, 0x8E2, 0x1680, 0x1680, 0x180E, 0x180E,
        0x2000, 0x200A, 0x200B, 0x200F, 0x2028, 0x2028, 0x2029, 0x2029, 0x202A, 0x202E,
        0x202F, 0x202F, 0x205F, 0x205F, 0x2060, 0x2064, 0x2066, 0x206F, 0x3000, 0x3000,
        0xD800, 0xDFFF, 0xE000, 0xF8FF, 0xFEFF, 0xFEFF, 0xFFF9, 0xFFFB, 0x110BD, 0x110BD,
        0x110CD, 0x110CD, 0x13430, 0x13438, 0x1BCA0, 0x1BCA3, 0x1D173, 0x1D17A, 0xE0001, 0xE0001,
        0xE0020, 0xE007F, 0xF0000, 0xFFFFD, 0x100000, 0x10FFFD,
    };

    private static boolean printable(int cp) {
        int lo = 0;
        int hi = EXCLUDED.length / 2 - 1;
        while (lo <= hi) { // binary search over the ranges
            int mid = (lo + hi) >>> 1;
            if (cp < EXCLUDED[2 * mid]) {
                hi = mid - 1;
            } else if (cp > EXCLUDED[2 * mid + 1]) {
                lo = mid + 1;
            } else {
                return false; // OA-TYPE-5
            }
        }
        return true;
    }

    /**
     * Return whether {@code t} is a valid message type.
     *
     * @param t the type
     * @return whether it is valid
     */
    public static boolean isValidType(String t) {
        return problem(t, false) == null;
    }

    /**
     * Return whether {@code p} is a valid pattern.
     *
     * @param p the pattern
     * @return whether it is valid
     */
    public static boolean isValidPattern(String p) {
        return problem(p, true) == null;
    }

    /**
     * Return {@code t} if it is a valid type.
     *
     * @param t the type
     * @param code the condition to raise (TYPE_INVALID, or API_MISUSE for a local caller)
     * @return {@code t}
     */
    public static String validateType(String t, ErrorCode code) {
        String problem = problem(t, false);
        if (problem != null) {
            throw org.openair.OpenAirException.of(code, "type '" + t + "' " + problem);
        }
        return t;
    }

    /**
     * Return {@code p} if it is a valid pattern, else PATTERN_INVALID.
     *
     * @param p the pattern
     * @return {@code p}
     * @throws RemoteProtocolException PATTERN_INVALID
     */
    public static String validatePattern(String p) {
        String problem = problem(p, true);
        if (problem != null) {
            throw new RemoteProtocolException(ErrorCode.PATTERN_INVALID,
                    "pattern '" + p + "' " + problem);
        }
        return p;
    }
}
