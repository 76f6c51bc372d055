// Entry point of the C# test assembly:
//   mono VWorldLod.Tests.exe [--manifest PATH]... [--broken PATH FIELD]... [--placements PATH]... [--names PATH]...
//                            [--georef PATH]... [--float32 PATH]... [--streaming PATH]... [--proxies PATH]... [--attributes PATH]... [--picking PATH]...
//                            [--glb-images PATH]... [--extract MANIFEST]... [--texture-bytes MANIFEST]...
// Always runs the self-contained tests; the options add tests on files made by the Python side.
using System;

namespace VWorldLod.Tests
{
    public static class Program
    {
        public static int Main(string[] args)
        {
            System.Threading.Thread.CurrentThread.CurrentCulture = System.Globalization.CultureInfo.InvariantCulture;
            var t = new TestRunner();
            PlanTests.Run(t);
            UnityLayerTests.Run(t);
            GeoreferenceTests.Run(t);
            EditorSceneTests.Run(t);
            StreamingTests.RunSelfContained(t);
            LevelChoiceTests.Run(t);
            ProxyTests.RunSelfContained(t);
            TextureImportTests.RunSelfContained(t);
            PickingTests.RunSelfContained(t);
            for (int i = 0; i < args.Length; i++)
            {
                if (args[i] == "--manifest" && i + 1 < args.Length) ExportedTests.RunManifest(t, args[++i]);
                else if (args[i] == "--broken" && i + 2 < args.Length) { ExportedTests.RunBroken(t, args[i + 1], args[i + 2]); i += 2; }
                else if (args[i] == "--placements" && i + 1 < args.Length) ExportedTests.RunPlacements(t, args[++i]);
                else if (args[i] == "--names" && i + 1 < args.Length) ExportedTests.RunNames(t, args[++i]);
                else if (args[i] == "--georef" && i + 1 < args.Length) GeoreferenceTests.RunCases(t, args[++i]);
                else if (args[i] == "--float32" && i + 1 < args.Length) GeoreferenceTests.RunFloat32(t, args[++i]);
                else if (args[i] == "--streaming" && i + 1 < args.Length) StreamingTests.Run(t, args[++i]);
                else if (args[i] == "--proxies" && i + 1 < args.Length) ProxyTests.Run(t, args[++i]);
                else if (args[i] == "--glb-images" && i + 1 < args.Length) TextureImportTests.RunGlbImages(t, args[++i]);
                else if (args[i] == "--extract" && i + 1 < args.Length) TextureImportTests.RunExtract(t, args[++i]);
                else if (args[i] == "--texture-bytes" && i + 1 < args.Length) TextureImportTests.RunTextureBytes(t, args[++i]);
                else if (args[i] == "--attributes" && i + 1 < args.Length) AttributeTests.Run(t, args[++i]);
                else if (args[i] == "--picking" && i + 1 < args.Length) PickingTests.Run(t, args[++i]);
                else
                {
                    Console.Error.WriteLine("unknown or incomplete argument: " + args[i]);
                    return 2;
                }
            }
            ExportedTests.PrintMeasurements();
            return t.Finish();
        }
    }
}
