// The texture memory the streamers hold, against a budget (StreamingSettings.TextureBudgetBytes),
// shared by TileStreamer (building levels) and ProxyStreamer (proxies). Bytes as Unity allocates
// them: width x height x bytes per texel (RGBA32 4, BC7/ASTC 4x4 1, DXT1 0.5), + 1/3 for the mip
// chain. Levels are accounted from the manifest's texture_size; proxies from what the backend
// measures of the loaded textures.
using System;

namespace VWorldLod
{
    public sealed class TextureBudget
    {
        readonly StreamingSettings settings;
        bool warned;

        public TextureBudget(StreamingSettings settings)
        {
            this.settings = settings;
        }

        /// <summary>Bytes resident now.</summary>
        public long Resident { get; private set; }

        /// <summary>The most bytes resident at once so far.</summary>
        public long Peak { get; private set; }

        public double Limit { get { return settings.TextureBudgetBytes; } }

        /// <summary>Whether the resident bytes plus extra would pass the budget.</summary>
        public bool Over(long extra = 0)
        {
            return Resident + extra > settings.TextureBudgetBytes;
        }

        /// <summary>Bytes of a width x height texture as Unity allocates it with these settings.</summary>
        public long Bytes(int width, int height)
        {
            double texels = (double)Math.Max(width, 0) * Math.Max(height, 0);
            return (long)Math.Ceiling(texels * settings.TextureBytesPerPixel * (settings.TextureMipmaps ? 4.0 / 3.0 : 1.0));
        }

        public void Add(long bytes)
        {
            Resident += bytes;
            if (Resident > Peak) Peak = Resident;
        }

        public void Remove(long bytes)
        {
            Resident -= bytes;
        }

        /// <summary>Says once (through report) that what the view needs passes the budget.</summary>
        public void WarnIfOver(Action<string> report)
        {
            if (warned || !Over()) return;
            warned = true;
            report("the textures the view needs take " + Mib(Resident) + " MiB, above the texture budget of " + Mib((long)Limit)
                   + " MiB: levels and proxies it does not need are released, the needed ones still load; raise the budget, lower the load radius, or import compressed textures (see the package docs, Streaming)");
        }

        static string Mib(long bytes)
        {
            return (bytes / (1024.0 * 1024.0)).ToString("0.0", System.Globalization.CultureInfo.InvariantCulture);
        }
    }
}
