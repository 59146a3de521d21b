package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertThrows;

import java.util.Arrays;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;
import org.junit.jupiter.params.ParameterizedTest;
import org.junit.jupiter.params.provider.ValueSource;
import org.junit.jupiter.api.Test;

/** The shim's JSON reader and writer. */
class JsonTest {
    @Test
    void readsEveryKindOfValue() {
        Object v = Json.parse(" {\"a\": [1, -2.5, true, false, null, \"x\\u00e9\\n\\\"\"],"
                + " \"b\": {}, \"c\": 12345678901234567890} ");
        Map<String, Object> m = Vectors.map(v);
        assertEquals(Arrays.asList(1L, -2.5, true, false, null, "x\u00e9\n\""), m.get("a"));
        assertEquals(Map.of(), m.get("b"));
        assertEquals(new java.math.BigInteger("12345678901234567890"), m.get("c"));
    }

    @Test
    void writesAsciiThatReadsBack() {
        Map<String, Object> m = new LinkedHashMap<>();
        m.put("s", "\u65e5\ud83c\udf89\t\u0001");
        m.put("n", List.of(1L, 2.0));
        m.put("z", null);
        String text = Json.write(m);
        assertEquals("{\"s\":\"\\u65e5\\ud83c\\udf89\\t\\u0001\",\"n\":[1,2.0],\"z\":null}", text);
        assertEquals(m, Json.parse(text));
    }

    @ParameterizedTest
    @ValueSource(strings = {"", "{", "[1,]x", "{\"a\" 1}", "\"\\q\"", "tru", "-", "[1] 2",
        "\"a\nb\""})
    void refusesWhatIsNotJson(String text) {
        assertThrows(IllegalArgumentException.class, () -> Json.parse(text));
    }
}
