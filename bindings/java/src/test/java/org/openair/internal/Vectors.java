package org.openair.internal;

import java.io.IOException;
import java.io.UncheckedIOException;
import java.nio.charset.StandardCharsets;
import java.nio.file.Files;
import java.nio.file.Path;
import java.util.HexFormat;
import java.util.List;
import java.util.Map;

/** Access to the shared cross-language vectors (spec/vectors), located by a system property. */
final class Vectors {
    private Vectors() {}

    /** @return the spec/vectors folder the pom passes as {@code openair.vectors} */
    static Path root() {
        String where = System.getProperty("openair.vectors");
        if (where == null) {
            throw new IllegalStateException("system property openair.vectors is not set");
        }
        return Path.of(where);
    }

    static byte[] bytes(String folder, String file) {
        try {
            return Files.readAllBytes(root().resolve(folder).resolve(file));
        } catch (IOException e) {
            throw new UncheckedIOException(e);
        }
    }

    @SuppressWarnings("unchecked")
    static Map<String, Object> json(String folder, String file) {
        return (Map<String, Object>) Json.parse(
                new String(bytes(folder, file), StandardCharsets.UTF_8));
    }

    @SuppressWarnings("unchecked")
    static List<Map<String, Object>> list(Map<String, Object> obj, String key) {
        return (List<Map<String, Object>>) obj.get(key);
    }

    @SuppressWarnings("unchecked")
    static Map<String, Object> map(Object o) {
        return (Map<String, Object>) o;
    }

    static String hex(byte[] data) {
        return HexFormat.of().formatHex(data);
    }

    static byte[] unhex(String text) {
        return HexFormat.of().parseHex(text);
    }
}
