package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;

import java.util.List;
import java.util.Map;
import java.util.stream.IntStream;
import java.util.stream.Stream;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.Arguments;
import org.junit.jupiter.params.provider.MethodSource;

/** Every row of spec/vectors/wildcards: validation (OA-TYPE-*, OA-MATCH-7) and matching. */
class WildcardVectorsTest {
    private static final List<Map<String, Object>> ROWS =
            Vectors.list(Vectors.json("wildcards", "wildcards.json"), "rows");

    static Stream<Arguments> rows() {
        return IntStream.range(0, ROWS.size()).mapToObj(i -> {
            Map<String, Object> r = ROWS.get(i);
            String label = i + ": " + shorten((String) r.get("pattern")) + " ~ "
                    + shorten((String) r.get("type"));
            return Arguments.of(label, r);
        });
    }

    private static String shorten(String s) {
        String shown = s.length() > 40 ? s.substring(0, 40) + "..." : s;
        return shown.replaceAll("\\p{Cntrl}", "?");
    }

    /** The precedence of the vectors: the pattern is checked first, then the type. */
    static String answer(String pattern, String type) {
        if (!Types.isValidPattern(pattern)) {
            return "invalid-pattern";
        }
        if (!Types.isValidType(type)) {
            return "invalid-type";
        }
        return Matcher.matches(pattern, type) ? "match" : "nomatch";
    }

    @ParameterizedTest(name = "{0}")
    @MethodSource("rows")
    void row(String label, Map<String, Object> r) {
        assertEquals(r.get("expected"), answer((String) r.get("pattern"), (String) r.get("type")),
                r.get("source").toString());
    }

    /** The embedded table of spec 5.1 (OA-TYPE-5) is the shared vector file, range by range. */
    @Test
    void excludedTableIsTheSharedVectorFile() {
        List<Map<String, Object>> ranges =
                Vectors.list(Vectors.json("unicode", "segment-exclusions.json"), "ranges");
        int[] expected = new int[2 * ranges.size()];
        for (int i = 0; i < ranges.size(); i++) {
            expected[2 * i] = codePoint(ranges.get(i).get("first"));
            expected[2 * i + 1] = codePoint(ranges.get(i).get("last"));
        }
        assertArrayEquals(expected, Types.EXCLUDED);
    }

    private static int codePoint(Object text) {
        return Integer.parseInt(((String) text).substring(2), 16); // "U+XXXX"
    }
}
