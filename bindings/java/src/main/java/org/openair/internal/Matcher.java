package org.openair.internal;

/**
 * The OpenAIR 1.0 type matcher (spec 5.2, OA-MATCH-1..6), the same for triggers and retrieves
 * (OA-MATCH-8).
 *
 * <p>Both sides are folded to lower case in ASCII only (OA-MATCH-1). The pattern matches when the
 * glob with {@code *} as "any run" matches the whole type (OA-MATCH-2, -3, -5, -6), or when the
 * pattern ends in {@code .*} and the type equals the pattern without those two characters, compared
 * literally (OA-MATCH-4: {@code A.*.B.*} does not match {@code A.X.B}). Linear time: no
 * backtracking.
 *
 * <p>Inputs are assumed valid ({@link Types}); invalid input still gets a deterministic answer.
 *
 * <p>Threading: stateless; thread-safe.
 */
public final class Matcher {
    private Matcher() {}

    /**
     * Return whether {@code pattern} matches the message type {@code type}.
     *
     * @param pattern the pattern
     * @param type the type
     * @return whether it matches
     */
    public static boolean matches(String pattern, String type) {
        String p = asciiLower(pattern);
        String t = asciiLower(type);
        if (glob(p, t)) {
            return true;
        }
        // OA-MATCH-4: `P.*` also matches the type equal to `P`, compared literally (so `A.*.B.*`
        // does not match `A.X.B`, and `A.*.*` does not match `A`).
        return p.endsWith(".*") && t.equals(p.substring(0, p.length() - 2));
    }

    static String asciiLower(String s) {
        char[] out = null;
        for (int i = 0; i < s.length(); i++) {
            char c = s.charAt(i);
            if (c >= 'A' && c <= 'Z') {
                if (out == null) {
                    out = s.toCharArray();
                }
                out[i] = (char) (c + 32);
            }
        }
        return out == null ? s : new String(out);
    }

    /** Whether the whole of {@code t} matches the {@code *}-glob {@code p}. */
    private static boolean glob(String p, String t) {
        String[] parts = p.split("\\*", -1);
        if (parts.length == 1) {
            return t.equals(p); // OA-MATCH-2: no star, equality only
        }
        String pre = parts[0];
        String post = parts[parts.length - 1];
        int end = t.length() - post.length();
        // OA-MATCH-6: prefix and suffix must not overlap.
        if (end < pre.length() || !t.startsWith(pre) || !t.endsWith(post)) {
            return false;
        }
        // OA-MATCH-3: the leftmost occurrence of each middle part is optimal for `*`-only globs.
        int at = pre.length();
        for (int i = 1; i < parts.length - 1; i++) {
            String middle = parts[i];
            int found = t.indexOf(middle, at);
            if (found < 0 || found + middle.length() > end) {
                return false;
            }
            at = found + middle.length();
        }
        return true;
    }
}
