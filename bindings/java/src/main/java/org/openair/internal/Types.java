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
 * (OA-TYPE-4; the kit applies the same limits to patterns). "Printable" follows the shared
 * vectors: control, format, surrogate, private-use, unassigned and separator characters are
 * refused (U+200B ZERO WIDTH SPACE included).
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

    private static boolean printable(int cp) {
        if (cp == ' ') {
            return false; // white space (OA-TYPE-1)
        }
        switch (Character.getType(cp)) {
            case Character.CONTROL:
            case Character.FORMAT:
            case Character.SURROGATE:
            case Character.PRIVATE_USE:
            case Character.UNASSIGNED:
            case Character.LINE_SEPARATOR:
            case Character.PARAGRAPH_SEPARATOR:
            case Character.SPACE_SEPARATOR:
                return false;
            default:
                return true;
        }
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
