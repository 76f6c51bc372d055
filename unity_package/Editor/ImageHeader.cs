// Size in pixels and alpha of an encoded JPEG or PNG, read from its header only (no decoding),
// for the texture import rules (max size, opaque or not) and the GPU-bytes accounting.
//
// Sources: PNG spec (ISO/IEC 15948) 11.2.2 IHDR (width, height: big-endian uint32 at bytes 16 and
// 20; colour type at byte 25: 4 = grey + alpha, 6 = RGBA) and 11.3.2.1 tRNS (transparency for
// other colour types); JPEG (ITU-T T.81) B.2.2: a frame header SOFn (0xFFC0..0xFFCF except C4, C8,
// CC) holds height then width as big-endian uint16 after the sample precision. JPEG has no alpha.
using System.IO;

namespace VWorldLod.EditorTools
{
    /// <summary>An image's pixel size and whether it carries alpha.</summary>
    public struct ImageInfo
    {
        public int Width, Height;
        public bool HasAlpha;
    }

    public static class ImageHeader
    {
        /// <summary>"image/png", "image/jpeg", or null when the bytes are neither.</summary>
        public static string Sniff(byte[] data)
        {
            if (data.Length >= 8 && data[0] == 0x89 && data[1] == (byte)'P' && data[2] == (byte)'N' && data[3] == (byte)'G') return "image/png";
            if (data.Length >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF) return "image/jpeg";
            return null;
        }

        /// <summary>The header's size and alpha; InvalidDataException when it is not a readable JPEG or PNG.</summary>
        public static ImageInfo Read(byte[] data)
        {
            string mime = Sniff(data);
            if (mime == "image/png") return Png(data);
            if (mime == "image/jpeg") return Jpeg(data);
            throw new InvalidDataException("not a JPEG or PNG image");
        }

        static int BigEndian(byte[] d, int at, int bytes)
        {
            int value = 0;
            for (int k = 0; k < bytes; k++) value = (value << 8) | d[at + k];
            return value;
        }

        static ImageInfo Png(byte[] d)
        {
            if (d.Length < 33 || BigEndian(d, 12, 4) != 0x49484452) throw new InvalidDataException("PNG without an IHDR chunk");
            var info = new ImageInfo { Width = BigEndian(d, 16, 4), Height = BigEndian(d, 20, 4) };
            int colourType = d[25];
            info.HasAlpha = colourType == 4 || colourType == 6;
            // tRNS gives palette / grey / RGB images transparency; it comes before IDAT.
            int at = 8;
            while (!info.HasAlpha && at + 8 <= d.Length)
            {
                int length = BigEndian(d, at, 4);
                int type = BigEndian(d, at + 4, 4);
                if (type == 0x74524E53) info.HasAlpha = true; // tRNS
                if (type == 0x49444154 || length < 0) break; // IDAT: no tRNS after it
                at += 12 + length;
            }
            return info;
        }

        static ImageInfo Jpeg(byte[] d)
        {
            int at = 2;
            while (at + 4 <= d.Length)
            {
                if (d[at] != 0xFF) throw new InvalidDataException("JPEG marker expected at byte " + at);
                int marker = d[at + 1];
                if (marker == 0xFF) { at++; continue; } // fill byte
                if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) { at += 2; continue; }
                int length = BigEndian(d, at + 2, 2);
                bool frame = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
                if (frame && at + 9 <= d.Length)
                    return new ImageInfo { Height = BigEndian(d, at + 5, 2), Width = BigEndian(d, at + 7, 2), HasAlpha = false };
                if (marker == 0xDA) break; // start of scan before any frame header
                at += 2 + length;
            }
            throw new InvalidDataException("JPEG without a frame header (SOFn)");
        }
    }
}
